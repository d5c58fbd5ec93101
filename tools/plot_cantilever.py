#!/usr/bin/python3
"""Draws the seed's Fig. 2: u_y along the beam axis, tsph against the exact solution.

    tools/plot_cantilever.py OUT_DIR [OUT_DIR ...] [-o fig2.png]

Each OUT_DIR is a `tsph run` output directory of a cantilever case (particles.pvd,
summary.json: the last frame's particles on the axis y = 0, against its
exact_displacement_y field), e.g. a run directory of `tsph converge`; an axis.csv beside
its summary.json (the layout of the former tsph-cantilever) is read as well.
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


def read_tsph_run(run):
    """axis data and a summary in the tsph-cantilever layout, from a `tsph run` directory."""
    with open(os.path.join(run, "summary.json")) as f:
        s = json.load(f)
    _, last = tsph_vtu.read_pvd(os.path.join(run, "particles.pvd"))[-1]
    grid = tsph_vtu.read_vtu(last)
    d = grid.point_data
    x0 = d["initial_position"]
    dx = s["resolved"]["spacing"]
    centre = 0.5 * (x0[:, 1].min() + x0[:, 1].max())
    on_axis = np.abs(x0[:, 1] - centre) < 1e-6 * dx
    dim = s["resolved"]["dimension"]
    if dim == 3:
        on_axis &= np.abs(x0[:, 2] - 0.5 * (x0[:, 2].min() + x0[:, 2].max())) < 1e-6 * dx
    order = np.argsort(x0[on_axis, 0])
    data = {"x": x0[on_axis, 0][order], "uy": d["displacement"][on_axis, 1][order],
            "uy_exact": d["exact_displacement_y"][on_axis][order]}
    errors = {e["name"]: e["value"] for e in s["errors"] if e["time"] == s["time"]}
    nx = int(round((x0[:, 0].max() - x0[:, 0].min()) / dx)) + 1
    ny = int(round((x0[:, 1].max() - x0[:, 1].min()) / dx)) + 1
    summary = {"dim": dim, "plane": s["resolved"]["plane"], "nodes": [nx, ny],
               "tip_error_percent": errors["tip_error_percent"]}
    return data, summary


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("runs", nargs="+", help="tsph run or tsph-cantilever output directories")
    parser.add_argument("-o", "--output", default="cantilever_fig2.png", help="PNG file to write")
    args = parser.parse_args()

    fig, ax = plt.subplots(figsize=(7, 4.2))
    exact_drawn = set()
    for run in args.runs:
        axis_file = os.path.join(run, "axis.csv")
        if os.path.isfile(os.path.join(run, "particles.pvd")):
            data, summary = read_tsph_run(run)
        elif os.path.isfile(axis_file):
            data = np.genfromtxt(axis_file, delimiter=",", names=True)
            with open(os.path.join(run, "summary.json")) as f:
                summary = json.load(f)
        else:
            parser.error(f"{run} holds neither particles.pvd nor axis.csv: run "
                         f"`tsph run tools/cases/cantilever_2d.toml --out {run}` first")
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
