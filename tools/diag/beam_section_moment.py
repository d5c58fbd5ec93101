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

DX, LOAD = 0.025, 8e7 * (0.1**3 / 12) / 1.0**2  # P = k E I / L^2 with k = 1 (the case file's load)
SIMPSON = np.array([1, 4, 2, 4, 1]) * DX / 3  # five particles across the thickness

for run in sys.argv[1:]:
    _, last = tsph_vtu.read_pvd(f"{run}/particles.pvd")[-1]
    g = tsph_vtu.read_vtu(last)
    X, x, s = g.point_data["initial_position"][:, :2], g.points[:, :2], g.point_data["stress"]
    tip = np.argmin(np.hypot(X[:, 0] - 1, X[:, 1]))
    out = []
    for col in (2, 10, 20, 30):
        column = np.where(np.abs(X[:, 0] - col * DX) < 1e-9)[0]
        column = column[np.argsort(X[column, 1])]
        chord = (x[column[-1]] - x[column[0]]) / np.linalg.norm(x[column[-1]] - x[column[0]])
        normal = np.array([chord[1], -chord[0]])  # the section's normal, along the deformed axis
        centre = x[column].mean(axis=0)
        moment = 0.0  # sum over the section of (r x sigma . normal) dA
        for weight, i in zip(SIMPSON, column):
            traction = np.array([[s[i, 0], s[i, 3]], [s[i, 3], s[i, 1]]]) @ normal
            r = x[i] - centre
            moment += (r[0] * traction[1] - r[1] * traction[0]) * weight
        applied = LOAD * (x[tip, 0] - centre[0])
        out.append(f"col {col}: M {moment:9.2f} ext {applied:9.2f} ratio {moment / applied:.4f}")
    print(run, "tip", x[tip], "|", "; ".join(out))
