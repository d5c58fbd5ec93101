"""Reads back the VTU/PVD output of a tsph run with an independent reader (XML +
numpy, tools/tsph_vtu.py) and checks the file structure and the fields' consistency.

    check_vtu.py OUT_DIR DIMENSION [--exact-velocity]
"""
import json
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tools"))
import numpy as np  # noqa: E402
import tsph_vtu  # noqa: E402


def main():
    out, dim = sys.argv[1], int(sys.argv[2])
    exact_velocity = "--exact-velocity" in sys.argv
    series = tsph_vtu.read_pvd(os.path.join(out, "particles.pvd"))
    summary = json.load(open(os.path.join(out, "summary.json")))
    assert len(series) == summary["output_frames"] >= 2, (len(series), summary["output_frames"])
    times = [t for t, _ in series]
    assert times[0] == 0.0 and all(b > a for a, b in zip(times, times[1:])), times
    assert abs(times[-1] - summary["time"]) <= 1e-12 * max(1.0, summary["time"]), (times[-1], summary["time"])
    n = summary["resolved"]["real_particles"]
    for time, path in series:
        g = tsph_vtu.read_vtu(path)
        d = g.point_data
        assert g.points.shape == (n, 3), g.points.shape
        assert np.all(g.points[:, dim:] == 0.0), "unused coordinates must be zero"
        assert np.array_equal(g.cells["types"], np.ones(n, np.uint8)), "vertex cells"
        assert np.array_equal(g.cells["connectivity"], np.arange(n)), "one point per cell"
        assert np.array_equal(g.cells["offsets"], np.arange(1, n + 1)), "offsets"
        assert np.array_equal(np.sort(d["id"]), np.arange(n)), "ids are a permutation"
        for name, components in (("velocity", 3), ("displacement", 3), ("stress", 6)):
            assert d[name].shape == (n, components), (name, d[name].shape)
            assert np.all(d[name][:, dim if name != "stress" else 6:] == 0.0) or name == "stress"
        assert np.all(np.isfinite(d["stress"]))
        s = d["stress"]  # XX YY ZZ XY YZ XZ
        mises = np.sqrt(0.5 * ((s[:, 0] - s[:, 1]) ** 2 + (s[:, 1] - s[:, 2]) ** 2 + (s[:, 2] - s[:, 0]) ** 2)
                        + 3.0 * (s[:, 3] ** 2 + s[:, 4] ** 2 + s[:, 5] ** 2))
        assert np.allclose(d["von_mises"], mises, rtol=1e-12, atol=1e-12 * max(1.0, mises.max()))
        assert np.allclose(d["density"], summary["resolved"]["rho"], rtol=0.05)
        if time == 0.0:
            assert np.all(d["displacement"] == 0.0)
            assert np.array_equal(d["initial_position"], g.points)
        if summary["resolved"]["kinematics"] == "small_strain":
            assert np.array_equal(d["initial_position"], g.points), "small strain: particles stay"
        if exact_velocity and time > 0.0:
            err = np.linalg.norm(d["velocity"][:, 0] - d["exact_velocity_x"])
            ref = np.linalg.norm(d["exact_velocity_x"])
            logged = [e["value"] for e in summary["errors"]
                      if e["name"] == "velocity_x_l2_percent" and e["time"] == time]
            assert len(logged) == 1 and abs(100.0 * err / ref - logged[0]) <= 1e-9 + 1e-9 * logged[0], \
                (100.0 * err / ref, logged)
    print(f"check_vtu: {len(series)} frames of {n} particles read back and consistent")


if __name__ == "__main__":
    main()
