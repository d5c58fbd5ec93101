#!/usr/bin/env python3
"""Diagnostic (docs/validation.md, Plasticity, "Symmetry planes and the wall"): variants of
the Taylor bar built from a whole-bar particle file (tools/cases/taylor_bar_3d.csv, or one
that `tsph validate taylor_bar` wrote), to tell the boundary treatments apart.

    tools/diag/taylor_bar_variants.py write DIR [PARTICLES.csv]
        DIR/half.toml     the half y >= 0, one symmetry plane y = 0 (and the wall)
        DIR/mirror.toml   two bars hitting each other at +-227 m/s: no wall, the impact
                          plane x = 0 inside the body (a frictionless rigid wall is its
                          mirror image)
    tsph run DIR/half.toml --out DIR/half; tsph run DIR/mirror.toml --out DIR/mirror
    tools/diag/taylor_bar_variants.py cylinder N PATH
        the whole bar at dx = R0 / N as tools/validate/taylor_bar.cpp writes it (R0 / 8:
        tsph run tools/cases/taylor_bar_3d.toml --set geometry.spacing=4e-4
        --set 'geometry.particle_file="PATH"', 16 min on 2 threads)
    tools/diag/taylor_bar_variants.py measure RUN_DIR [DX]
        R / R0 of the impact-face particles that start on the true radius along the
        lattice axes (what tsph validate taylor_bar reports), the face's convex hull as
        sqrt(A / A0), and L / L0 of the far end, at every frame.

Needs numpy (and scipy for the hull); reads the frames with tools/tsph_vtu.py.
"""
import glob
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import tsph_vtu  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
R0 = 3.2e-3


def write(directory, particles):
    os.makedirs(directory, exist_ok=True)
    lines = open(particles).read().splitlines()
    header = [l for l in lines if l.startswith("#") or l.startswith("x,")]
    rows = [l.split(",") for l in lines if not (l.startswith("#") or l.startswith("x,"))]
    half, mirror = [], []
    for x, y, z, v, vx, vy, vz, g in rows:
        if float(y) >= -1e-12:  # the half: the plane's particles carry half their volume
            half.append([x, y, z, repr(float(v) / 2) if abs(float(y)) < 1e-12 else v, vx, vy, vz, g])
        if float(x) == 0.0:  # the impact face is inside the pair: a whole cell's volume
            mirror.append([x, y, z, repr(2 * float(v)), "0", vy, vz, g])
        else:
            mirror.append([x, y, z, v, vx, vy, vz, g])
            mirror.append([repr(-float(x)), y, z, v, repr(-float(vx)), vy, vz, g])
    for name, body in (("half", half), ("mirror", mirror)):
        with open(os.path.join(directory, name + ".csv"), "w") as f:
            f.write("\n".join(header + [",".join(r) for r in body]) + "\n")
    case = open(os.path.join(ROOT, "tools/cases/taylor_bar_3d.toml")).read()
    case = case.replace('particle_file = "taylor_bar_3d.csv"', 'particle_file = "@PARTICLES@"')
    wall = case.index('[[boundary]]\nname = "wall"')
    side = case.index('[[boundary]]\nname = "side"')
    plane = ('[[boundary]]\nname = "plane_y"\ntype = "symmetry"\n'
             'region = { type = "half_space", point = [0.0, 0.0, 0.0], normal = [0.0, -1.0, 0.0] }\n')
    with open(os.path.join(directory, "half.toml"), "w") as f:
        path = os.path.abspath(os.path.join(directory, "half.csv"))
        f.write((case[:side] + plane + case[side:]).replace("@PARTICLES@", path))
    with open(os.path.join(directory, "mirror.toml"), "w") as f:
        end = case.index("[output]")
        path = os.path.abspath(os.path.join(directory, "mirror.csv"))
        f.write((case[:wall] + case[end:]).replace("@PARTICLES@", path))
    print(f"{len(half)} particles in {directory}/half.csv, {len(mirror)} in {directory}/mirror.csv")


def cylinder(n, path):
    """tools/validate/taylor_bar.cpp write_cylinder (the whole bar) at dx = R0 / n."""
    length = 32.4e-3
    dx = R0 / n
    nx = round(length / dx)
    cells_at_node, cells = {}, 0
    for j in range(-n - 1, n + 1):
        for k in range(-n - 1, n + 1):
            if (j + 0.5) ** 2 + (k + 0.5) ** 2 <= n * n:
                cells += 1
                for a in (0, 1):
                    for b in (0, 1):
                        cells_at_node[(j + a, k + b)] = cells_at_node.get((j + a, k + b), 0) + 1
    scale = np.pi * R0 * R0 / (cells * dx * dx)
    with open(path, "w") as f:
        f.write(f"# Taylor bar: dx = R0 / {n}; written by tools/diag/taylor_bar_variants.py\n")
        f.write("x,y,z,volume,vx,vy,vz,group\n")
        for i in range(nx + 1):
            for node in sorted(cells_at_node):
                count = cells_at_node[node]
                volume = (0.5 if i in (0, nx) else 1.0) * dx ** 3 * 0.25 * count * scale
                group = 2 if i == nx else (1 if count <= 2 else 0)
                f.write("%.10g,%.10g,%.10g,%.10g,%s,0,0,%d\n" % (i * dx, node[0] * dx, node[1] * dx, volume,
                                                               "0" if i == 0 else "-227", group))


def measure(run, dx):
    frames = sorted(glob.glob(os.path.join(run, "particles_*.vtu")))
    n = int(round(R0 / dx))
    area0 = None
    for path in frames:
        grid = tsph_vtu.read_vtu(path)
        x0, x = grid.point_data["initial_position"], grid.points
        node = np.rint(x0 / dx).astype(int)
        face = node[:, 0] == 0
        tips = face & (((np.abs(node[:, 1]) == n) & (node[:, 2] == 0)) | ((node[:, 1] == 0) & (np.abs(node[:, 2]) == n)))
        radius = np.hypot(x[tips, 1], x[tips, 2]).mean() / R0
        far = np.abs(x0[:, 0] - x0[:, 0].max()) < 1e-9 * x0[:, 0].max()
        length = x[far, 0].mean() / x0[:, 0].max()
        hull = ""
        try:
            from scipy.spatial import ConvexHull
            area = ConvexHull(x[face][:, 1:3]).volume
            area0 = area0 or area
            # A half bar's face is half a disc: the ratio holds all the same.
            hull = f"  hull sqrt(A/A0) {np.sqrt(area / area0):.4f}"
        except ImportError:
            pass
        print(f"{os.path.basename(path)}  R/R0 {radius:.4f}  L/L0 {length:.4f}{hull}")


if __name__ == "__main__":
    if len(sys.argv) >= 3 and sys.argv[1] == "write":
        write(sys.argv[2], sys.argv[3] if len(sys.argv) > 3 else os.path.join(ROOT, "tools/cases/taylor_bar_3d.csv"))
    elif len(sys.argv) == 4 and sys.argv[1] == "cylinder":
        cylinder(int(sys.argv[2]), sys.argv[3])
    elif len(sys.argv) >= 3 and sys.argv[1] == "measure":
        measure(sys.argv[2], float(sys.argv[3]) if len(sys.argv) > 3 else 0.8e-3)
    else:
        sys.exit(__doc__)
