#!/usr/bin/env python3
"""The energy production of a 2D case's semi-discrete operator L, split by blocks
(docs/notes/2026-11-27-wall-corners.md, section 3; the maps and L as in
tools/diag/energy_production.py):

    for cfl in 0.0125 0.025 0.05; do build/tools/tsph spectrum tools/diag/free_block_2d.toml \\
        --set geometry.spacing=0.1 --set time.cfl=$cfl --write-map --out /tmp/spm_$cfl; done
    python3 tools/diag/energy_blocks.py --E 1e6 --nu 0.3 --rho 1000 --dx 0.1 \\
        /tmp/spm_0.0125:0.0125 /tmp/spm_0.025:0.025 /tmp/spm_0.05:0.05

Prints L's growth and lowest frequencies as it is and with the momentum replaced by the
exact (energy-weighted) adjoint of the stress update, and the production range of the
coupling blocks (v <- sigma with sigma <- v), of sigma <- sigma and of v <- v.
"""
import argparse

import numpy as np

from energy_production import SteppedOperator, material_arguments


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("maps", nargs=3, help="DIR:CFL of three tsph spectrum --write-map runs")
    material_arguments(parser)
    a = parser.parse_args()
    op = SteppedOperator(a.maps, a.E, a.nu, a.rho, a.dx)
    L, h = op.operator, op.weights
    vel = [k for k, r in enumerate(op.rows) if r["field"] in ("vx", "vy")]
    st = [k for k, r in enumerate(op.rows) if r["field"] not in ("vx", "vy")]
    adjoint = L.copy()
    adjoint[np.ix_(vel, st)] = -np.linalg.solve(h[np.ix_(vel, vel)], L[np.ix_(st, vel)].T @ h[np.ix_(st, st)])
    for name, m in (("as is", L), ("momentum = -adjoint of the stress update", adjoint)):
        w = np.linalg.eigvals(m)
        frequencies = np.sort(np.abs(w.imag[w.imag > 1e-3]))
        print(f"{name}: max Re {w.real.max():.4g} /s; lowest frequencies (rad/s):", np.round(frequencies[:6], 2))
        print("   largest production", op.production(m)[0][-1])

    def block(rows, cols):
        m = np.zeros_like(L)
        m[np.ix_(rows, cols)] = L[np.ix_(rows, cols)]
        return m

    for name, m in (("v<-s and s<-v (the coupling)", block(vel, st) + block(st, vel)), ("s<-s", block(st, st)),
                    ("v<-v", block(vel, vel))):
        kappa = op.production(m)[0]
        print(f"{name}: production range [{kappa[0]:.4g}, {kappa[-1]:.4g}] /s")


if __name__ == "__main__":
    main()
