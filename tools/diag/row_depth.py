#!/usr/bin/env python3
"""At which depth a one-sided row takes its tangential derivative (docs/notes/2026-11-27-adjoint-momentum.md).

    python3 tools/diag/row_depth.py

A strip 5 particles thick (dx = 0.025 m, the 41 x 5 cantilever's lattice), virtual particles at the
cell centres, the code's operators re-written here: the half step's linear interpolation (Shepard
where its moments are singular) to the virtual particles, then the full step's corrected gradient
relative to the interpolated value, cubic spline, h = alpha dx. Printed: d/dx of v = x y (exact: y)
at the particles of the middle column, and for the top rows the depth the row's derivative belongs
to against the stencil centroid's depth (what surface_extrapolation moves by).
"""
import numpy as np
def w3(q):  # cubic spline shape, support 2
    return np.where(q < 1, 1 - 1.5*q**2 + 0.75*q**3, np.where(q < 2, 0.25*(2-q)**3, 0.0))
def dw3(q):
    return np.where(q < 1, -3*q + 2.25*q**2, np.where(q < 2, -0.75*(2-q)**2, 0.0))
dx = 0.025; nx = 41; ny = 5
R = np.array([(i*dx, -0.05 + j*dx) for j in range(ny) for i in range(nx)])
Vr = np.full(len(R), dx*dx)  # volumes (edges would be halves; irrelevant mid-beam)
Vc = np.array([((i+0.5)*dx, -0.05 + (j+0.5)*dx) for j in range(ny-1) for i in range(nx-1)])
Vv = np.full(len(Vc), dx*dx)
def weights(x, pts, vol, h):
    d = pts - x; r = np.linalg.norm(d, axis=1); q = r/h; sel = q < 2
    d, r, q, vol = d[sel], r[sel], q[sel], vol[sel]
    W = vol*w3(q)
    # linear interpolation weights
    P = np.hstack([np.ones((len(d),1)), d/h])
    Mm = (P*W[:,None]).T @ P
    try:
        c = np.linalg.solve(Mm, np.eye(3)[0]); wi = W*(P@c)
    except np.linalg.LinAlgError:
        wi = W/W.sum()
    with np.errstate(invalid='ignore', divide='ignore'):
        g = (vol*dw3(q)/np.where(r>0, r, 1))[:,None]*d  # grad wrt x_J (direction d)
    M = g.T @ d
    G = np.linalg.solve(M, g.T).T   # rows: corrected gradient weights
    D = G - wi[:,None]*G.sum(axis=0)  # relative to the interpolated value
    return np.where(sel)[0], wi, D
for alpha in (0.6, 1.2):
    h = alpha*dx
    f = lambda p: p[:,0]*p[:,1]   # v_x = x y: d/dx = y
    fr = f(R)
    # virtual values by the half step's interpolation
    fv = np.zeros(len(Vc))
    for k, x in enumerate(Vc):
        idx, wi, _ = weights(x, R, Vr, h); fv[k] = wi @ fr[idx]
    out = []
    for j in range(ny):
        I = j*nx + 20
        idx, wi, D = weights(R[I], Vc, Vv, h)
        est = D[:,0] @ fv[idx]
        out.append(f"y={R[I,1]:+.4f}: d_x(xy) {est:+.5f} (exact {R[I,1]:+.5f})")
    # the moment-weighted effective: fit est = c * y
    print(f"alpha {alpha}:"); print('  ' + '\n  '.join(out))
print('D only (exact virtual values), and the centroid depth:')
for alpha in (0.6, 1.2):
    h = alpha*dx
    for j in (4, 3):
        I = j*nx + 20
        idx, wi, D = weights(R[I], Vc, Vv, h)
        fvx = Vc[idx,0]*Vc[idx,1]
        est = D[:,0] @ fvx
        d = Vc[idx] - R[I]; r = np.linalg.norm(d, axis=1)
        cen = d[r < 2*h].mean(axis=0)
        print(f"  alpha {alpha} y={R[I,1]:+.4f}: D-only {est:+.5f}; shift {R[I,1]-est:+.5f}; centroid depth {cen[1]:+.5f}")
