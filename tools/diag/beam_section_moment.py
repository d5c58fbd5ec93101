#!/usr/bin/env python3
"""The bending moment the stress carries across material columns of the 41 x 5 large-deflection
beam against the dead tip load's moment (docs/notes/2026-11-27-adjoint-momentum.md):

    for kc in current reference; do
      tsph run tools/cases/cantilever_2d_large.toml --set geometry.spacing=0.025 \
          --set method.kernel_configuration=$kc --set time.end=1.2 --set damping.rest_velocity=0 \
          --set damping.rest_kinetic_energy=0 --set output.every=0 --set 'output.times=[1.2]' --out /tmp/km_$kc
    done
    python3 tools/diag/beam_section_moment.py /tmp/km_current /tmp/km_reference

Each column of particles (initial x = col dx) is taken as a section along its current chord;
sigma . n integrated by Simpson's rule over its five particles. A rough measure (the columns
are not normal to the deformed axis): compare runs, not the ratio with 1.
"""
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import tsph_vtu  # noqa: E402

for run in sys.argv[1:]:
    fr = tsph_vtu.read_pvd(f'{run}/particles.pvd'); t, p = fr[-1]
    kc = run
    g = tsph_vtu.read_vtu(p); X = g.point_data['initial_position'][:, :2]; x = g.points[:, :2]; s = g.point_data['stress']
    tip = np.argmin(np.hypot(X[:,0]-1, X[:,1]))
    out = []
    for col in (2, 10, 20, 30):
        sel = np.where(np.abs(X[:,0] - col*0.025) < 1e-9)[0]
        sel = sel[np.argsort(X[sel,1])]
        # section direction: along the column's current chord
        a, b = x[sel[0]], x[sel[-1]]; e = (b - a)/np.linalg.norm(b - a); nrm = np.array([e[1], -e[0]])  # axis tangent ~ nrm
        c = x[sel].mean(axis=0)
        # traction on the section with normal nrm: sigma . nrm ; moment about c: sum (r x t) * dA (trapezoid weights)
        w = np.array([1,4,2,4,1])*0.025/3
        M = 0.0
        for k, i in enumerate(sel):
            S = np.array([[s[i,0], s[i,3]], [s[i,3], s[i,1]]])
            tr = S @ nrm; r = x[i] - c
            M += (r[0]*tr[1] - r[1]*tr[0]) * w[k]
        # the tip load's moment: P = k E I / L^2 with k = 1 (the case file's load)
        Ptot = 8e7 * (0.1**3/12) / 1.0**2
        Mext = Ptot * (x[tip,0] - c[0])
        out.append(f"col {col}: M {M:9.2f} ext {Mext:9.2f} ratio {M/Mext:.4f}")
    print(kc, 'tip', x[tip], '|', '; '.join(out))
