#!/usr/bin/env python3
"""Plots of `tsph validate` (tools/tsph_validate.cpp): every OUT/<case>/<series>.csv as
OUT/<case>/<series>.png. Column 0 is x; a column whose name starts with "ref " is drawn
as a line (the reference), every other as markers (tsph). The two comment lines at the
top give the title and the axis labels.

    python3 tools/plot_validation.py out/validate
"""
import csv
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def plot(path: pathlib.Path) -> None:
    lines = path.read_text().splitlines()
    title, labels = "", ("", "")
    while lines and lines[0].startswith("#"):
        text = lines.pop(0)[1:].strip()
        if text.startswith("x:"):
            x_part, _, y_part = text.partition("; y:")
            labels = (x_part[2:].strip(), y_part.strip())
        else:
            title = text
    rows = list(csv.reader(lines))
    if len(rows) < 2:
        return
    header = rows[0]
    # A row shorter than the header (a run that stopped mid-row) is padded with NaN.
    data = [[float(v) if v else float("nan") for v in r] + [float("nan")] * (len(header) - len(r))
            for r in rows[1:] if r]
    x = [r[0] for r in data]
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for k, name in enumerate(header[1:], start=1):
        y = [r[k] for r in data]
        if name.startswith("ref "):
            ax.plot(x, y, "-", lw=1.2, label=name)
        else:
            ax.plot(x, y, "o", ms=3.5, label=name)
    ax.set_title(f"{path.parent.name}: {title}", fontsize=9)
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path.with_suffix(".png"), dpi=110)
    plt.close(fig)


def main() -> int:
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    out = pathlib.Path(sys.argv[1])
    paths = sorted(out.glob("*/*.csv"))
    for p in paths:
        plot(p)
    print(f"plot_validation.py: {len(paths)} plots in {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
