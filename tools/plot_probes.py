#!/usr/bin/python3
"""Probe time series of a `tsph run` (probe_<name>.csv): displacement, velocity and
von Mises stress against time, one row of panels per probe.

    tools/plot_probes.py OUT_DIR [--probe NAME ...] [-o probes.png]
"""
import argparse
import glob
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("run", help="tsph run output directory")
    parser.add_argument("--probe", action="append", help="probe name (default: all)")
    parser.add_argument("-o", "--output", default="probes.png", help="PNG file to write")
    args = parser.parse_args()
    files = sorted(glob.glob(os.path.join(args.run, "probe_*.csv")))
    if args.probe:
        files = [os.path.join(args.run, f"probe_{p}.csv") for p in args.probe]
    files = [f for f in files if os.path.isfile(f)]
    if not files:
        parser.error(f"no probe_*.csv in {args.run}: add [[output.probe]] entries to the case")
    fig, axes = plt.subplots(len(files), 3, figsize=(13, 3.2 * len(files)), squeeze=False)
    for row, path in enumerate(files):
        data = np.genfromtxt(path, delimiter=",", names=True)
        name = os.path.basename(path)[len("probe_"):-len(".csv")]
        axes_names = [a for a in "xyz" if f"u{a}" in data.dtype.names]
        t = data["t"]
        for a in axes_names:
            axes[row][0].plot(t, data[f"u{a}"], label=f"$u_{a}$")
            axes[row][1].plot(t, data[f"v{a}"], label=f"$v_{a}$")
        axes[row][2].plot(t, 1e-6 * data["von_mises"], color="C3")
        axes[row][0].set_ylabel(f"{name}\ndisplacement (m)")
        axes[row][1].set_ylabel("velocity (m/s)")
        axes[row][2].set_ylabel("von Mises stress (MPa)")
        for ax in axes[row]:
            ax.set_xlabel("t (s)")
            ax.grid(alpha=0.3)
        axes[row][0].legend(fontsize=8)
        axes[row][1].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.output, dpi=150)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
