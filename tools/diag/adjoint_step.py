#!/usr/bin/env python3
"""The free block's step with the momentum made the adjoint of the stress update (an experiment
on the step maps; docs/notes/2026-11-27-adjoint-momentum.md).

    for cfl in 0.0125 0.025 0.05 0.225 0.9; do
      tsph spectrum tools/diag/free_block_2d.toml --set geometry.spacing=0.1 --set time.cfl=$cfl \
          --write-map --out /tmp/spm_$cfl
      tsph spectrum /tmp/nob.toml --set geometry.spacing=0.1 --set time.cfl=$cfl --write-map --out /tmp/nob_$cfl
    done      # /tmp/nob.toml: the same block without its [[boundary]] (no characteristic stage)
    python3 tools/diag/adjoint_step.py --E 1e6 --nu 0.3 --rho 1000 --dx 0.1 /tmp/spm /tmp/nob

The stress rows of the maps give the semi-discrete stress update B (sigma' = C grad(S v), S the
half step's interpolation, grad the full step's gradient: B = C D S). With H the energy weights,
A = -M^-1 B^T H_sigma is the momentum whose stress power is returned exactly. The "adjoint step"
keeps the map's stress update (the characteristic stage included) and replaces its momentum by
    v' = v + dt A (sigma + sigma') / 2.
Printed: the spectral radius of the code's step and of the adjoint step at each CFL, and A applied
to stress fields whose divergence is known (1 inside: what the first rows inside the free faces get).
"""
import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from energy_production import SteppedOperator, material_arguments  # noqa: E402

SMALL, LARGE = (0.0125, 0.025, 0.05), (0.0125, 0.05, 0.225, 0.9)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("free", help="prefix of the block's maps, PREFIX_<cfl>")
    parser.add_argument("bulk", help="prefix of the maps of the same block without boundary conditions")
    material_arguments(parser)
    a = parser.parse_args()
    ops = {name: SteppedOperator([f"{prefix}_{cfl}:{cfl}" for cfl in SMALL], a.E, a.nu, a.rho, a.dx)
           for name, prefix in (("free", a.free), ("bulk", a.bulk))}
    rows = ops["free"].rows
    n = len(rows)
    velocity = [k for k, r in enumerate(rows) if r["field"] in ("vx", "vy")]
    stress = [k for k, r in enumerate(rows) if r["field"] not in ("vx", "vy")]
    h = ops["free"].weights
    lame = a.E * a.nu / ((1 + a.nu) * (1 - 2 * a.nu))
    c = np.sqrt((lame + a.E / (1 + a.nu)) / a.rho)

    def adjoint(op):
        b = op.operator[np.ix_(stress, velocity)]
        return -np.linalg.solve(h[np.ix_(velocity, velocity)], b.T @ h[np.ix_(stress, stress)])

    def adjoint_step(g, dt, momentum):
        gss, gsv = g[np.ix_(stress, stress)], g[np.ix_(stress, velocity)]
        step = np.zeros((n, n))
        step[np.ix_(stress, velocity)], step[np.ix_(stress, stress)] = gsv, gss
        step[np.ix_(velocity, velocity)] = np.eye(len(velocity)) + 0.5 * dt * momentum @ gsv
        step[np.ix_(velocity, stress)] = 0.5 * dt * momentum @ (np.eye(len(stress)) + gss)
        return step

    def radius(m):
        return np.abs(np.linalg.eigvals(m)).max() - 1.0

    momentum = {name: adjoint(op) for name, op in ops.items()}
    print("spectral radius - 1: the code's step | adjoint step (bulk A) | adjoint step (A of the free block's B)")
    for cfl in LARGE:
        g = np.fromfile(f"{a.free}_{cfl}/map.f64", "<f8").reshape(n, n)
        dt = cfl * a.dx / c
        print(f"  CFL {cfl:7}: {radius(g):+.3e} | {radius(adjoint_step(g, dt, momentum['bulk'])):+.3e} | "
              f"{radius(adjoint_step(g, dt, momentum['free'])):+.3e}")

    z = a.rho * c  # the maps' stress unit
    where = {k: (int(rows[k]["i"]), int(rows[k]["j"])) for k in range(n)}
    ni = max(i for i, _ in where.values()) + 1
    nj = max(j for _, j in where.values()) + 1
    lower = -0.5 * a.dx * (ni - 1)

    def divergence(field):
        s = np.array([field(rows[k]["field"], lower + a.dx * where[k][0], lower + a.dx * where[k][1]) / z for k in stress])
        f = momentum["bulk"] @ s * z
        grid = np.zeros((nj, ni, 2))
        for b, k in enumerate(velocity):
            i, j = where[k]
            grid[j, i, 0 if rows[k]["field"] == "vx" else 1] = f[b]
        return grid

    unit = divergence(lambda f, x, y: x if f == "sxx" else 0.0)[nj // 2, ni // 2, 0]
    np.set_printoptions(precision=3, suppress=True, linewidth=200)
    for label, field, component in (
        ("sigma_xy = y (x component; 1 inside, the faces y = const carry sigma_xy)", lambda f, x, y: y if f == "sxy" else 0.0, 0),
        ("sigma_xx = 2 x y, sigma_xy = 1/4 - y^2 (equilibrated, traction-free at y = +-1/2; x component, exact 0)",
         lambda f, x, y: 2 * x * y if f == "sxx" else (0.25 - y * y) if f == "sxy" else 0.0, 0),
    ):
        print(f"A applied to {label}, per unit divergence (top row: largest y):")
        print(divergence(field)[::-1, :, component] / unit)


if __name__ == "__main__":
    main()
