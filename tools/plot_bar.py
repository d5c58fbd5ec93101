#!/usr/bin/python3
"""Bar velocity (and stress) profiles against the exact solution, one panel per output
time, from a `tsph run tools/cases/bar.toml` output directory (seed section 4.1).

    tools/plot_bar.py OUT_DIR [OUT_DIR ...] [-o bar_profiles.png]

Several directories (e.g. alpha = 0.6, 1.2, 1.6: `tsph table1` writes them as
out/bar-table1/alpha*) are drawn on the same panels.
"""
import argparse
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import tsph_vtu  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("runs", nargs="+", help="tsph run output directories of the bar case")
    parser.add_argument("-o", "--output", default="bar_profiles.png", help="PNG file to write")
    parser.add_argument("--stress", action="store_true", help="draw the stress instead of the velocity")
    args = parser.parse_args()
    field, exact_field, unit = (("stress", "exact_stress_xx", "stress $\\sigma_{xx}$ (MPa)") if args.stress
                                else ("velocity", "exact_velocity_x", "velocity $v_x$ (m/s)"))
    scale = 1e-6 if args.stress else 1.0
    runs = []
    for run in args.runs:
        pvd = os.path.join(run, "particles.pvd")
        if not os.path.isfile(pvd):
            parser.error(f"{pvd} does not exist: run `tsph run tools/cases/bar.toml --out {run}` first")
        with open(os.path.join(run, "summary.json")) as f:
            summary = json.load(f)
        frames = [(t, p) for t, p in tsph_vtu.read_pvd(pvd) if t > 0.0]
        runs.append((run, summary, frames))
    times = [t for t, _ in runs[0][2]]
    fig, axes = plt.subplots(1, len(times), figsize=(5 * len(times), 3.8), squeeze=False)
    for k, t in enumerate(times):
        ax = axes[0][k]
        for n, (run, summary, frames) in enumerate(runs):
            path = dict(frames).get(t)
            if path is None:
                continue
            g = tsph_vtu.read_vtu(path)
            d = g.point_data
            x = d["initial_position"][:, 0]
            order = np.argsort(x)
            value = d[field][:, 0] if d[field].ndim > 1 else d[field]
            if n == 0:
                ax.plot(x[order], scale * d[exact_field][order], "-", color="0.3", lw=1.5, label="exact")
            err = [e["value"] for e in summary["errors"]
                   if e["time"] == t and e["name"] == ("stress_xx" if args.stress else "velocity_x") + "_l2_percent"]
            label = f"alpha {summary['resolved']['alpha']}" + (f": L2 error {err[0]:.3g} %" if err else "")
            ax.plot(x[order], scale * value[order], "o", ms=3, mfc="none", label=label)
        ax.set_title(f"t = {1e3 * t:g} ms")
        ax.set_xlabel("x (m)")
        ax.set_ylabel(unit)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.output, dpi=150)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
