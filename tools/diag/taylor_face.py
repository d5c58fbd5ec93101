#!/usr/bin/env python3
"""The Taylor bar's impact face in one frame (docs/notes/2026-12-06-taylor-bar-shape-and-energy.md).

    python3 tools/diag/taylor_face.py FRAME.vtu N

FRAME: a frame of a Taylor bar run (the fields initial_position; the quarter or the
whole bar), N: particles across the radius (dx = R0 / N). Prints, over R0:
  * axes: the mean radius of the face particles that start at (0, R0, 0) and (0, 0, R0)
    (what `tsph validate taylor_bar` checks);
  * diagonal: the largest radius of a face particle within 7.5 degrees of 45 degrees;
  * largest: the largest radius of any particle, with its initial row and its height;
  * the largest face radius in 5-degree bins of the angle atan2(z, y), 0-45 degrees
    (an empty bin is left out).
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import tsph_vtu  # noqa: E402

R0 = 3.2e-3


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    grid = tsph_vtu.read_vtu(sys.argv[1])
    n = int(sys.argv[2])
    dx = R0 / n
    x = grid.points
    x0 = grid.point_data["initial_position"]
    r = np.hypot(x[:, 1], x[:, 2])
    face = np.abs(x0[:, 0]) < 1e-9 * R0
    j, k = x0[:, 1] / dx, x0[:, 2] / dx
    on_axes = face & (((np.abs(np.abs(j) - n) < 1e-6) & (np.abs(k) < 1e-6)) |
                      ((np.abs(np.abs(k) - n) < 1e-6) & (np.abs(j) < 1e-6)))
    angle = np.degrees(np.arctan2(np.abs(x[:, 2]), np.abs(x[:, 1])))
    angle = np.minimum(angle, 90.0 - angle)  # 0 on the axes, 45 on the diagonals
    diagonal = face & (np.abs(angle - 45.0) < 7.5)
    if not on_axes.any() or not diagonal.any():
        sys.exit(f"taylor_face: no face particle on the axes or near the diagonal at dx = R0 / {n}: "
                 "is N the run's particles across the radius?")
    far = int(np.argmax(r))
    print(f"axes {r[on_axes].mean() / R0:.4f}; diagonal {r[diagonal].max() / R0:.4f}; "
          f"largest {r[far] / R0:.4f} (initial row {int(round(x0[far, 0] / dx))}, x = {x[far, 0] / dx:.2f} dx)")
    bins = []
    for start in range(0, 45, 5):
        m = face & (angle >= start) & ((angle < start + 5) | (start == 40))  # 45 itself in the last
        if m.any():
            bins.append(f"{start}-{start + 5}: {r[m].max() / R0:.3f}")
    print("face, largest r / R0 by angle: " + ", ".join(bins))


if __name__ == "__main__":
    main()
