#!/usr/bin/env python3
"""Diagnostic (docs/validation.md, Plasticity, "The midpoint return"; the check itself is
`tsph validate plastic_j2_shear_2d`, against the same equations in C++):
the homogeneous block sheared at gamma_dot = 0.05 1/s (plane strain, J2 with linear
isotropic and kinematic hardening, a driven body) against the Jaumann-rate elastoplastic
ODE: the elastic phase in closed form (sigma_xy = G sin(gamma), sigma_xx = -sigma_yy =
G (1 - cos(gamma))) up to first yield, found by bisection, then
    dsigma/dt = C : (D - lambda_dot n) + W sigma - sigma W,
    dalpha/dt = 2/3 H_kin lambda_dot n + W alpha - alpha W,
    lambda_dot = 2 G n : D / (2 G + 2/3 H_kin + 2/3 H_iso),   deps_p/dt = sqrt(2/3) lambda_dot,
by RK4 (converged to 1e-15 between h = 2e-3 and 1e-3).

    build/tools/tsph run tools/cases/homogeneous_2d.toml \\
      --set 'boundary.0.velocity_gradient=[0.0, 0.05, 0.0, 0.0]' \\
      --set 'initial.velocity_gradient=[0.0, 0.05, 0.0, 0.0]' --set material.model='"j2"' \\
      --set material.yield_stress=2e4 --set material.isotropic_hardening=1e5 \\
      --set material.kinematic_hardening=5e4 --set material.plane='"strain"' --set time.end=4.0 \\
      --set 'output.times=[1.0, 2.0, 3.0, 4.0]' --set 'output.fields=["stress","id","plastic"]' --out DIR
    tools/diag/j2_simple_shear.py DIR [H_KIN]

Prints, per frame, the worst particle's stress error (relative to the largest reference
component) and plastic-strain error (relative to the reference): 1.5e-9 and 5.5e-10 at
t = 4 s since the midpoint return (2026-11-27, session 11; the radial return: 9.7e-6 and
1.2e-7, first order in dt).
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import tsph_vtu  # noqa: E402

E, NU = 1e6, 0.3
G = E / (2 * (1 + NU))
K = E / (3 * (1 - 2 * NU))
LAME = K - 2 * G / 3
YIELD, H_ISO = 2e4, 1e5
H_KIN = float(sys.argv[2]) if len(sys.argv) > 2 else 5e4
RATE = 0.05
L = np.zeros((3, 3))
L[0, 1] = RATE
D, W = 0.5 * (L + L.T), 0.5 * (L - L.T)


def elastic(t):
    g = RATE * t
    s = np.zeros((3, 3))
    s[0, 0], s[1, 1] = G * (1 - np.cos(g)), -G * (1 - np.cos(g))
    s[0, 1] = s[1, 0] = G * np.sin(g)
    return s


def plastic_rhs(y):
    s, a = y[:9].reshape(3, 3), y[9:18].reshape(3, 3)
    xi = s - np.trace(s) / 3 * np.eye(3) - a
    n = xi / np.linalg.norm(xi)
    lam = 2 * G * np.sum(n * D) / (2 * G + 2 / 3 * H_KIN + 2 / 3 * H_ISO)
    dp = lam * n
    ds = LAME * np.trace(D - dp) * np.eye(3) + 2 * G * (D - dp) + W @ s - s @ W
    da = 2 / 3 * H_KIN * dp + W @ a - a @ W
    return np.concatenate([ds.ravel(), da.ravel(), [np.sqrt(2 / 3) * lam]])


def first_yield():
    lo, hi = 0.0, 10.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if np.sqrt(1.5) * np.linalg.norm(elastic(mid)) < YIELD else (lo, mid)
    return 0.5 * (lo + hi)


def reference(t, t_yield, h=1e-3):
    if t <= t_yield:
        return elastic(t), 0.0
    y = np.zeros(19)
    y[:9] = elastic(t_yield).ravel()
    n = max(1, int(round((t - t_yield) / h)))
    h = (t - t_yield) / n
    for _ in range(n):
        k1 = plastic_rhs(y)
        k2 = plastic_rhs(y + h / 2 * k1)
        k3 = plastic_rhs(y + h / 2 * k2)
        k4 = plastic_rhs(y + h * k3)
        y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return y[:9].reshape(3, 3), y[18]


def main():
    t_yield = first_yield()
    print(f"first yield at t = {t_yield:.6f} s (gamma = {RATE * t_yield:.6f}), H_kin = {H_KIN:g}")
    for t, path in tsph_vtu.read_pvd(os.path.join(sys.argv[1], "particles.pvd"))[1:]:
        grid = tsph_vtu.read_vtu(path)
        s, ep = grid.point_data["stress"], grid.point_data["plastic_strain"]  # VTK order xx yy zz xy yz xz
        ref, ep_ref = reference(t, t_yield)
        scale = np.abs(ref).max()
        err = max(np.abs(s[:, 0] - ref[0, 0]).max(), np.abs(s[:, 1] - ref[1, 1]).max(),
                  np.abs(s[:, 2] - ref[2, 2]).max(), np.abs(s[:, 3] - ref[0, 1]).max()) / scale
        ep_err = np.abs(ep - ep_ref).max() / ep_ref if ep_ref > 0 else np.abs(ep).max()
        print(f"t = {t:.4g} s  sigma_xy {s[:, 3].mean():.6f} (ref {ref[0, 1]:.6f})  eps_p {ep.mean():.8f} "
              f"(ref {ep_ref:.8f})  worst stress {err:.2e}  worst eps_p {ep_err:.2e}")


if __name__ == "__main__":
    main()
