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

DX, NX, NY = 0.025, 41, 5
REAL = np.array([(i * DX, -0.05 + j * DX) for j in range(NY) for i in range(NX)])
VIRTUAL = np.array([((i + 0.5) * DX, -0.05 + (j + 0.5) * DX) for j in range(NY - 1) for i in range(NX - 1)])
VOLUME = DX * DX  # every particle's (the faces' halves do not matter in the middle column)


def shape(q):  # cubic spline, support 2
    return np.where(q < 1, 1 - 1.5 * q**2 + 0.75 * q**3, np.where(q < 2, 0.25 * (2 - q) ** 3, 0.0))


def slope(q):
    return np.where(q < 1, -3 * q + 2.25 * q**2, np.where(q < 2, -0.75 * (2 - q) ** 2, 0.0))


def row(x, sources, h):
    """The row of x over `sources`: its neighbours, interpolation weights and gradient weights
    relative to the interpolated value."""
    d = sources - x
    r = np.linalg.norm(d, axis=1)
    near = r / h < 2
    d, r = d[near], r[near]
    w = VOLUME * shape(r / h)
    p = np.hstack([np.ones((len(d), 1)), d / h])
    try:  # linear interpolation, Shepard where its moments are singular
        value = w * (p @ np.linalg.solve((p * w[:, None]).T @ p, np.eye(3)[0]))
    except np.linalg.LinAlgError:
        value = w / w.sum()
    g = (VOLUME * slope(r / h) / np.where(r > 0, r, 1))[:, None] * d
    gradient = np.linalg.solve(g.T @ d, g.T).T  # corrected: exact for linear fields
    return np.where(near)[0], value, gradient - value[:, None] * gradient.sum(axis=0)


def main():
    field = REAL[:, 0] * REAL[:, 1]  # v = x y: d/dx = y
    for alpha in (0.6, 1.2):
        h = alpha * DX
        at_virtual = np.zeros(len(VIRTUAL))
        for k, x in enumerate(VIRTUAL):  # the half step's interpolation
            near, value, _ = row(x, REAL, h)
            at_virtual[k] = value @ field[near]
        print(f"alpha {alpha}:")
        for j in range(NY):
            i = j * NX + NX // 2
            near, _, gradient = row(REAL[i], VIRTUAL, h)
            print(f"  y={REAL[i, 1]:+.4f}: d_x(xy) {gradient[:, 0] @ at_virtual[near]:+.5f} (exact {REAL[i, 1]:+.5f})")
    print("the full step alone (exact virtual values), and the stencil centroid's depth:")
    for alpha in (0.6, 1.2):
        h = alpha * DX
        for j in (NY - 1, NY - 2):
            i = j * NX + NX // 2
            near, _, gradient = row(REAL[i], VIRTUAL, h)
            estimate = gradient[:, 0] @ (VIRTUAL[near, 0] * VIRTUAL[near, 1])
            centroid = (VIRTUAL[near] - REAL[i]).mean(axis=0)
            print(f"  alpha {alpha} y={REAL[i, 1]:+.4f}: D-only {estimate:+.5f}; shift {REAL[i, 1] - estimate:+.5f}; "
                  f"centroid depth {centroid[1]:+.5f}")


if __name__ == "__main__":
    main()
