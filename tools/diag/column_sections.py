#!/usr/bin/env python3
"""The twisting column's sections, frame by frame (docs/notes/2026-11-29-column-twist-and-spin-diagnostics.md).

    python3 tools/diag/column_sections.py RUN_DIR DX [EVERY]

RUN_DIR holds particles.pvd of a `tsph validate twisting_column_alpha*` run (e.g.
/tmp/colq/twisting_column_alpha0.6/dx0.2500_alpha0.6), written with the fields velocity
and displacement; DX its spacing. For every EVERY-th frame it prints:
  * the kinetic energy (per unit density) of the edge, face and inner particles of the
    lattice (edges: on two side faces; faces: on one);
  * the RMS of the section's second difference of the displacement (along y and z, one-sided
    at the faces) / DX, per class: zero for a section that turns rigidly or warps
    harmonically, large where a class breaks away from its section;
  * at mid-length and at the tip: the mean radial and tangential deviation of the edge and
    face particles from the section's best-fit rotation, / DX, and their axial displacement.
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import tsph_vtu  # noqa: E402


def section_laplacian(field):
    out = np.zeros_like(field)
    for axis in (1, 2):
        a = np.moveaxis(field, axis, 0)
        r = np.zeros_like(a)
        r[1:-1] = a[1:-1] - 0.5 * (a[2:] + a[:-2])
        r[0] = a[0] - 2 * a[1] + a[2]
        r[-1] = a[-1] - 2 * a[-2] + a[-3]
        out += np.moveaxis(r, 0, axis)
    return out


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    run, dx = sys.argv[1], float(sys.argv[2])
    every = int(sys.argv[3]) if len(sys.argv) > 3 else 4
    frames = tsph_vtu.read_pvd(os.path.join(run, "particles.pvd"))
    for t, path in frames[::every]:
        g = tsph_vtu.read_vtu(path if os.path.isabs(path) else os.path.join(run, path))
        X, u, v, x = g.point_data["initial_position"], g.point_data["displacement"], g.point_data["velocity"], g.points
        i = np.round(X[:, 0] / dx).astype(int)
        j = np.round((X[:, 1] - X[:, 1].min()) / dx).astype(int)
        k = np.round((X[:, 2] - X[:, 2].min()) / dx).astype(int)
        n = j.max()
        grid = np.zeros((i.max() + 1, n + 1, k.max() + 1, 3))
        grid[i, j, k] = u
        lap = section_laplacian(grid)[i, j, k]
        side_j, side_k = (j == 0) | (j == n), (k == 0) | (k == k.max())
        edge = side_j & side_k
        face = (side_j | side_k) & ~edge
        inner = ~(side_j | side_k)
        classes = (("edge", edge), ("face", face), ("inner", inner))
        kinetic = " ".join(f"{name} {0.5 * np.sum(v[m] ** 2):.3g}" for name, m in classes)
        second = " ".join(f"{name} {np.sqrt(np.mean(np.sum(lap[m] ** 2, 1))) / dx:.3e}" for name, m in classes)
        print(f"t = {t:.4f} s  KE/rho: {kinetic}  |  second difference / dx: {second}")
        for section in (i.max() // 2, i.max()):
            m = i == section
            r0 = X[m][:, 1:] - X[m][:, 1:].mean(0)
            r = x[m][:, 1:] - x[m][:, 1:].mean(0)
            phi = np.arctan2(np.sum(r0[:, 0] * r[:, 1] - r0[:, 1] * r[:, 0]), np.sum(r0 * r))
            c, s = np.cos(phi), np.sin(phi)
            turned = r0 @ np.array([[c, -s], [s, c]]).T
            dev = r - turned
            length = np.linalg.norm(turned, axis=1).clip(1e-12)
            radial = np.sum(dev * turned, 1) / length
            tangential = (dev[:, 1] * turned[:, 0] - dev[:, 0] * turned[:, 1]) / length
            axial = x[m][:, 0] - X[m][:, 0]
            e, f = edge[m], face[m]
            print(f"    section i = {section}, turned {phi:+.3f} rad: edges radial {radial[e].mean() / dx:+.3f} "
                  f"tangential {tangential[e].mean() / dx:+.3f} axial {axial[e].mean() / dx:+.3f}; faces radial "
                  f"{radial[f].mean() / dx:+.3f} tangential {tangential[f].mean() / dx:+.3f} axial "
                  f"{axial[f].mean() / dx:+.3f} (dx)")


if __name__ == "__main__":
    main()
