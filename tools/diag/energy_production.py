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
tools/diag/energy_blocks.py splits K by blocks with the same functions.
(docs/notes/2026-11-27-wall-corners.md.)
"""
import argparse
import csv

import numpy as np
import scipy.linalg


def material_arguments(parser):
    for key in ("E", "nu", "rho", "dx"):
        parser.add_argument(f"--{key}", type=float, required=True)


class SteppedOperator:
    """L (full coordinates), G's range Q, the energy weights H and the rows' fields."""

    def __init__(self, maps, young, nu, rho, dx):
        lame = young * nu / ((1 + nu) * (1 - 2 * nu))
        self.mu = young / (2 * (1 + nu))
        c = np.sqrt((lame + 2 * self.mu) / rho)
        self.maps = []
        for item in maps:
            directory, cfl = item.rsplit(":", 1)
            self.rows = list(csv.DictReader(open(f"{directory}/map_rows.csv")))
            n = len(self.rows)
            g = np.fromfile(f"{directory}/map.f64", "<f8").reshape(n, n)
            self.maps.append((g, float(cfl) * dx / c))
        n = len(self.rows)
        u, s, _ = np.linalg.svd(self.maps[0][0])
        self.range = u[:, : int((s > 1e-9).sum())]
        steps = np.array([dt for _, dt in self.maps[:3]])
        self.coefficients = np.linalg.inv(np.vander(steps, 3, increasing=True))  # (G - I) / dt = sum_k dt^k X_k
        slopes = [(g - np.eye(n)) / dt for g, dt in self.maps[:3]]
        self.terms = [sum(self.coefficients[k, j] * slopes[j] for j in range(3)) for k in range(3)]
        self.operator = self.terms[0]
        self.fields = {}
        for k, row in enumerate(self.rows):
            self.fields.setdefault(int(row["particle"]), {})[row["field"]] = k
        z = rho * c  # the map's stress unit
        compliance = np.full((3, 3), -nu / young)
        np.fill_diagonal(compliance, 1 / young)
        self.weights = np.zeros((n, n))
        for f in self.fields.values():
            normal = [f["sxx"], f["syy"], f["szz"]]
            self.weights[np.ix_(normal, normal)] = z * z * compliance
            self.weights[f["sxy"], f["sxy"]] = z * z / self.mu
            self.weights[f["vx"], f["vx"]] = self.weights[f["vy"], f["vy"]] = rho

    def fit_error(self):
        """The fourth map, if given, against the fit through the first three, on G's range
        (a constrained coordinate's row of (G - I) / dt is -1 / dt, not polynomial)."""
        g, dt = self.maps[3]
        q = self.range
        slope = q.T @ ((g - np.eye(len(self.rows))) / dt) @ q
        fitted = q.T @ sum(self.terms[k] * dt**k for k in range(3)) @ q
        return np.abs(slope - fitted).max() / np.abs(slope).max()

    def production(self, operator):
        """Eigenvalues and vectors (full coordinates) of (H A + A^T H) / 2 against H on G's range."""
        q, h = self.range, self.weights
        kappa, vectors = scipy.linalg.eigh(q.T @ (0.5 * (h @ operator + operator.T @ h)) @ q, q.T @ h @ q)
        return kappa, q @ vectors


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("maps", nargs="+", help="DIR:CFL of tsph spectrum --write-map runs (three or more)")
    material_arguments(parser)
    a = parser.parse_args()
    op = SteppedOperator(a.maps, a.E, a.nu, a.rho, a.dx)
    print(f"{len(op.rows)} unknowns, G's range {op.range.shape[1]}")
    if len(op.maps) > 3:
        print(f"fourth map against the fit: {op.fit_error():.2e} (relative)")
    q = op.range
    growth = np.linalg.eigvals(q.T @ op.operator @ q).real.max()
    kappa, vectors = op.production(op.operator)
    print(f"largest growth rate of L: {growth:.4g} 1/s; largest energy production rate (K against H): {kappa[-1]:.4g} 1/s")
    v = vectors[:, -1]
    ni = max(int(row["i"]) for row in op.rows) + 1
    nj = max(int(row["j"]) for row in op.rows) + 1
    grid = np.zeros((nj, ni))
    for f in op.fields.values():
        k = list(f.values())
        first = op.rows[k[0]]
        grid[int(first["j"]), int(first["i"])] = 0.5 * v[k] @ op.weights[np.ix_(k, k)] @ v[k]
    np.set_printoptions(precision=2, linewidth=200, suppress=True)
    print("energy of K's leading vector, % per particle (top row: largest j):")
    print(grid[::-1] / grid.sum() * 100)


if __name__ == "__main__":
    main()
