#!/usr/bin/env python3
"""Where a 2D plane-strain case's semi-discrete scheme makes energy, from its step maps.

    tsph spectrum CASE --set time.cfl=C --write-map --out DIR_C     # for three small CFLs
    python3 tools/diag/energy_production.py --E 1e6 --nu 0.3 --rho 1000 --dx 0.1 \
        DIR_0.0125:0.0125 DIR_0.025:0.025 DIR_0.05:0.05

The step map is G(dt) = I + dt L + dt^2 B + dt^3 C (the two half steps and the boundary
stage are polynomial in dt), so three maps give the semi-discrete operator L exactly
(the script prints how well a fourth point, if given, agrees). G first projects onto the
boundary conditions' constraints (a free particle's traction, a wall's normal velocity),
so L is taken on G's range. With H the energy weights (rho |v|^2 / 2 + sigma : C^-1 : sigma
/ 2 per particle, equal volumes), a conservative scheme has H L + L^T H = 0; the script
prints the largest growth rate of L (1/s), the largest eigenvalue of K = (H L + L^T H) / 2
against H (the fastest energy production any state can have) and the energy map (%) of
K's leading vector on the lattice: where the scheme makes energy.
(docs/notes/2026-11-27-wall-corners.md.)
"""
import argparse
import csv

import numpy as np
import scipy.linalg


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("maps", nargs="+", help="DIR:CFL of tsph spectrum --write-map runs (three or more)")
    parser.add_argument("--E", type=float, required=True)
    parser.add_argument("--nu", type=float, required=True)
    parser.add_argument("--rho", type=float, required=True)
    parser.add_argument("--dx", type=float, required=True)
    a = parser.parse_args()
    lame = a.E * a.nu / ((1 + a.nu) * (1 - 2 * a.nu))
    mu = a.E / (2 * (1 + a.nu))
    c = np.sqrt((lame + 2 * mu) / a.rho)
    z = a.rho * c  # the map's stress unit
    maps = []
    for item in a.maps:
        directory, cfl = item.rsplit(":", 1)
        rows = list(csv.DictReader(open(f"{directory}/map_rows.csv")))
        n = len(rows)
        g = np.fromfile(f"{directory}/map.f64", "<f8").reshape(n, n)
        maps.append((rows, g, float(cfl) * a.dx / c))
    rows, g0, _ = maps[0]
    u, s, _ = np.linalg.svd(g0)
    q = u[:, : int((s > 1e-9).sum())]
    r = q.shape[1]
    print(f"{len(rows)} unknowns, G's range {r}")
    reduced = [((q.T @ g @ q - np.eye(r)) / dt, dt) for _, g, dt in maps]
    fit = reduced[:3]
    steps = np.array([dt for _, dt in fit])
    weights = np.linalg.inv(np.vander(steps, 3, increasing=True))[0]
    operator = sum(w * m for w, (m, _) in zip(weights, fit))
    if len(reduced) > 3:  # the fourth map against the cubic through the first three and L
        m3, dt3 = reduced[3]
        coefficients = np.linalg.inv(np.vander(steps, 3, increasing=True))
        fitted = sum(sum(coefficients[k, j] * fit[j][0] for j in range(3)) * dt3**k for k in range(3))
        print(f"fourth map against the fit: {np.abs(m3 - fitted).max() / np.abs(m3).max():.2e} (relative)")
    compliance = np.full((3, 3), -a.nu / a.E)
    np.fill_diagonal(compliance, 1 / a.E)
    fields = {}
    for k, row in enumerate(rows):
        fields.setdefault(int(row["particle"]), {})[row["field"]] = k
    h_full = np.zeros((len(rows), len(rows)))
    for f in fields.values():
        normal = [f["sxx"], f["syy"], f["szz"]]
        for i in range(3):
            for j in range(3):
                h_full[normal[i], normal[j]] = z * z * compliance[i, j]
        h_full[f["sxy"], f["sxy"]] = z * z / mu
        h_full[f["vx"], f["vx"]] = h_full[f["vy"], f["vy"]] = a.rho
    h = q.T @ h_full @ q
    growth = np.linalg.eigvals(operator).real.max()
    production = 0.5 * (h @ operator + operator.T @ h)
    kappa, vectors = scipy.linalg.eigh(production, h)
    print(f"largest growth rate of L: {growth:.4g} 1/s; largest energy production rate (K against H): {kappa[-1]:.4g} 1/s")
    v = q @ vectors[:, -1]
    ni = max(int(row["i"]) for row in rows) + 1
    nj = max(int(row["j"]) for row in rows) + 1
    grid = np.zeros((nj, ni))
    for f in fields.values():
        k = list(f.values())
        first = rows[k[0]]
        grid[int(first["j"]), int(first["i"])] = 0.5 * v[k] @ h_full[np.ix_(k, k)] @ v[k]
    np.set_printoptions(precision=2, linewidth=200, suppress=True)
    print("energy of K's leading vector, % per particle (top row: largest j):")
    print(grid[::-1] / grid.sum() * 100)


if __name__ == "__main__":
    main()
