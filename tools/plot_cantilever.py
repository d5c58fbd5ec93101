#!/usr/bin/python3
"""Draws the seed's Fig. 2: u_y along the beam axis, tsph against the exact solution.

    tools/plot_cantilever.py OUT_DIR [OUT_DIR ...] [-o fig2.png]

Each OUT_DIR is a tsph-cantilever output directory (axis.csv, summary.json).
"""
import argparse
import json
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("runs", nargs="+", help="tsph-cantilever output directories")
    parser.add_argument("-o", "--output", default="cantilever_fig2.png", help="PNG file to write")
    args = parser.parse_args()

    fig, ax = plt.subplots(figsize=(7, 4.2))
    exact_drawn = set()
    for run in args.runs:
        axis_file = os.path.join(run, "axis.csv")
        if not os.path.isfile(axis_file):
            parser.error(f"{axis_file} does not exist: run tsph-cantilever --out {run} first")
        data = np.genfromtxt(axis_file, delimiter=",", names=True)
        with open(os.path.join(run, "summary.json")) as f:
            summary = json.load(f)
        label = f"{summary['dim']}D" + (f" plane {summary['plane']}" if summary["dim"] == 2 else "")
        key = (summary["dim"], summary["plane"])
        if key not in exact_drawn:
            ax.plot(data["x"], 1e3 * data["uy_exact"], "-", color="0.3", lw=1.5,
                    label=f"exact, {label}" + (" (seed eq. 5)" if summary["dim"] == 2 else " (Timoshenko beam)"))
            exact_drawn.add(key)
        ax.plot(data["x"], 1e3 * data["uy"], "o", ms=3.5, mfc="none",
                label=f"Taylor-SPH, {label}, {summary['nodes'][0]} x {summary['nodes'][1]}: "
                      f"tip error {summary['tip_error_percent']:.2f} %")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("vertical displacement $u_y$ (mm)")
    ax.set_title("Cantilever under an end load: displacement along the axis")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    fig.savefig(args.output, dpi=150)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
