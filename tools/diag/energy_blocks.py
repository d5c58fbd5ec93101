#!/usr/bin/env python3
"""The energy production of the free block's semi-discrete operator L, split by blocks
(docs/notes/2026-11-27-wall-corners.md, section 3). Scratch analysis for the 11 x 11 free
block of tools/diag/free_block_2d.toml (E 1e6, nu 0.3, rho 1000, dx 0.1 hard-coded):

    for cfl in 0.0125 0.025 0.05; do build/tools/tsph spectrum tools/diag/free_block_2d.toml \
        --set geometry.spacing=0.1 --set time.cfl=$cfl --write-map --out /tmp/spm_$cfl; done
    python3 tools/diag/energy_blocks.py /tmp/spm

Prints L's growth and lowest frequencies as it is and with the momentum replaced by the
exact (energy-weighted) adjoint of the stress update, and the production range of the
coupling blocks (v <- sigma with sigma <- v), of sigma <- sigma and of v <- v.
"""
import numpy as np, csv, sys
E,nu,rho,dx=1e6,0.3,1000.0,0.1
lame=E*nu/((1+nu)*(1-2*nu)); mu=E/(2*(1+nu)); c=np.sqrt((lame+2*mu)/rho); z=rho*c
pre=sys.argv[1]
maps=[]
for cfl in (0.0125,0.025,0.05):
    d=f'{pre}_{cfl}'
    rows=list(csv.DictReader(open(d+'/map_rows.csv'))); n=len(rows)
    maps.append((np.fromfile(d+'/map.f64','<f8').reshape(n,n), cfl*dx/c))
steps=np.array([dt for _,dt in maps]); W=np.linalg.inv(np.vander(steps,3,increasing=True))[0]
L=sum(w*(g-np.eye(n))/dt for w,(g,dt) in zip(W,maps))
comp=np.full((3,3),-nu/E); np.fill_diagonal(comp,1/E)
H=np.zeros((n,n)); fields={}
for k,r in enumerate(rows): fields.setdefault(int(r['particle']),{})[r['field']]=k
for f in fields.values():
    st=[f['sxx'],f['syy'],f['szz']]
    for a in range(3):
        for b in range(3): H[st[a],st[b]]=z*z*comp[a,b]
    H[f['sxy'],f['sxy']]=z*z/mu; H[f['vx'],f['vx']]=H[f['vy'],f['vy']]=rho
vel=[k for k,r in enumerate(rows) if r['field'] in ('vx','vy')]
st=[k for k,r in enumerate(rows) if r['field'] not in ('vx','vy')]
Lp=L.copy()
Hv=H[np.ix_(vel,vel)]; Hs=H[np.ix_(st,st)]
Lp[np.ix_(vel,st)]=-np.linalg.solve(Hv, L[np.ix_(st,vel)].T@Hs)
for name,M in (('as is',L),('momentum = -adjoint of the stress update',Lp)):
    w=np.linalg.eigvals(M)
    osc=np.sort(np.abs(w.imag[(w.imag>1e-3)]))
    print(f'{name}: max Re {w.real.max():.4g} /s; lowest frequencies (rad/s):', np.round(osc[:6],2))
    K=0.5*(H@M+M.T@H)
    import scipy.linalg as sl
    # restrict K to the range of G (maps[0]) to skip constrained coordinates
    U,s,_=np.linalg.svd(maps[0][0]); Q=U[:,:int((s>1e-9).sum())]
    kap=sl.eigh(Q.T@K@Q, Q.T@H@Q, eigvals_only=True)
    print('   largest production', kap[-1])
import scipy.linalg as sl
U,s,_=np.linalg.svd(maps[0][0]); Q=U[:,:int((s>1e-9).sum())]
def part(mask_rows, mask_cols):
    M=np.zeros_like(L); M[np.ix_(mask_rows,mask_cols)]=L[np.ix_(mask_rows,mask_cols)]; return M
for name,M in (('v<-s and s<-v (the coupling)', part(vel,st)+part(st,vel)), ('s<-s', part(st,st)), ('v<-v', part(vel,vel))):
    K=0.5*(H@M+M.T@H)
    kap=sl.eigh(Q.T@K@Q, Q.T@H@Q, eigvals_only=True)
    print(f'{name}: production range [{kap[0]:.4g}, {kap[-1]:.4g}] /s')
