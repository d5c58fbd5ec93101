#!/usr/bin/python3
"""The seed's Table 1 error study from `tsph run tools/cases/bar.toml` runs at several
alpha: L2 velocity error against alpha at each output time, beside the paper's values.

    build/tools/tsph table1 --out out/bar-table1      # or tools/run.sh
    tools/plot_table1.py out/bar-table1/alpha* -o table1.png

Prints the table too (alpha, then the error in percent at each output time).
"""
import argparse
import json
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

PAPER = {0.6: 1e-3, 1.2: 1e-2, 1.6: 10.0}  # seed Table 1, L2 error (%)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("runs", nargs="+", help="tsph run output directories of the bar case")
    parser.add_argument("-o", "--output", default="table1.png", help="PNG file to write")
    args = parser.parse_args()
    rows = []
    for run in args.runs:
        path = os.path.join(run, "summary.json")
        if not os.path.isfile(path):
            parser.error(f"{path} does not exist: run `tsph run tools/cases/bar.toml --out {run}` first")
        with open(path) as f:
            s = json.load(f)
        errors = {e["time"]: e["value"] for e in s["errors"]
                  if e["name"] == "velocity_x_l2_percent" and e["time"] > 0.0}
        rows.append((s["resolved"]["alpha"], errors))
    rows.sort()
    times = sorted({t for _, e in rows for t in e})
    print("alpha " + " ".join(f"{1e3 * t:>12g} ms" for t in times) + "   paper")
    for alpha, errors in rows:
        print(f"{alpha:5g} " + " ".join(f"{errors.get(t, float('nan')):15.4g}" for t in times)
              + f"   {PAPER.get(alpha, float('nan')):g}")
    fig, ax = plt.subplots(figsize=(6, 4))
    alphas = [a for a, _ in rows]
    for t in times:
        ax.semilogy(alphas, [max(e.get(t, float("nan")), 1e-14) for _, e in rows], "o-",
                    label=f"tsph, t = {1e3 * t:g} ms")
    paper = [(a, PAPER[a]) for a in alphas if a in PAPER]
    if paper:
        ax.semilogy(*zip(*paper), "s--", color="0.3", label="seed Table 1")
    ax.set_xlabel("alpha = h / dx")
    ax.set_ylabel("L2 velocity error (%)")
    ax.set_title("1D bar: error against alpha (cubic spline, CFL 1)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.output, dpi=150)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
