#!/usr/bin/env bash
# Issue 14, item 4 (docs/reliability.md, "Unphysical state"): a blow-up is caught before
# it is written. The compressed block (tests/cases/compressed_block.toml) at a velocity
# gradient of -1e4 1/s (main 3277c60: exit 0, density 1.7e131) and -1e3 1/s (exit 3, the
# last frame at density 5e41) must exit 3 with the diagnosis, and every frame written
# (VTU, read back with tools/tsph_vtu.py) and the checkpoint left must hold a finite
# state within the monitor's bounds (the frame at t = 0 holds the case's initial state as
# given: its speed is not checked); at -2.8e2 1/s, stopped later, the checkpoint of the
# last good step is left. -1e2 1/s (corner speed 0.34 c_p) runs to the end.
#   tsph_monitor_checks.sh TSPH SOURCE_DIR
set -u
export OMP_WAIT_POLICY=PASSIVE
tsph="$1"
src="$2"
block="$src/tests/cases/compressed_block.toml"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
cd "$work" || exit 1

# frames_within DIR: every VTU frame of DIR is finite, rho / rho0 in [0.2, 5], |v - v_mean|
# below 1.2 c_p after t = 0 (summary.json's p_wave_speed), |sigma| below 5 rho0 c_p^2.
frames_within() {
  /usr/bin/python3 - "$1" "$src/tools" <<'PY'
import json, os, sys
sys.path.insert(0, sys.argv[2])
import numpy as np
import tsph_vtu
out = sys.argv[1]
summary = json.load(open(os.path.join(out, "summary.json")))
rho0, c_p = summary["resolved"]["rho"], summary["resolved"]["p_wave_speed"]
series = tsph_vtu.read_pvd(os.path.join(out, "particles.pvd"))
assert len(series) >= 1, "no frame"
for t, path in series:
    d = tsph_vtu.read_vtu(path).point_data
    for name in ("velocity", "stress", "density"):
        assert np.all(np.isfinite(d[name])), (path, name, "non-finite")
    ratio = d["density"] / rho0
    assert ratio.max() <= 5.0 and ratio.min() >= 0.2, (path, ratio.min(), ratio.max())
    v = d["velocity"]
    # the monitor takes the mass-weighted mean; the plain mean differs at the faces
    assert t == 0.0 or np.linalg.norm(v - v.mean(axis=0), axis=1).max() <= 1.2 * c_p, (path, "speed")
    s = d["stress"]  # XX YY ZZ XY YZ XZ
    norm = np.sqrt((s[:, :3] ** 2).sum(axis=1) + 2.0 * (s[:, 3:] ** 2).sum(axis=1))
    assert norm.max() <= 5.0 * rho0 * c_p ** 2, (path, "stress", norm.max())
print(len(series), "frames, last at t =", series[-1][0])
PY
}

# run_diverges NAME GRADIENT [ARGS...]: exit 3, the diagnosis names the particle, the frames are
# within the bounds, summary.json says diverged at the last good time.
run_diverges() {
  local name="$1" g="$2"
  shift 2
  "$tsph" run "$block" --quiet --out "$name" --set "initial.velocity_gradient=[$g,0.0,0.0,$g]" \
    --set output.every=1 --set output.checkpoint_every=1 "$@" >"$name.out" 2>"$name.err"
  local got=$?
  [ "$got" -eq 3 ] || fail "$name: exit $got, expected 3: $(head -c 600 "$name.err")"
  grep -Eq "diverged at step [0-9]+ \(t = [0-9.e+-]+ s\): real particle [0-9]+ at \([0-9.e+-]+, [0-9.e+-]+\) (has an unphysical|moves at an unphysical|has no virtual)" "$name.err" ||
    fail "$name: the diagnosis does not name the particle and the criterion: $(head -c 600 "$name.err")"
  grep -q '"status": "diverged"' "$name/summary.json" || fail "$name: summary.json does not say diverged"
  frames_within "$name" || fail "$name: a frame holds a state beyond the monitor's bounds"
  ls "$name"/checkpoint_*.bin >/dev/null 2>&1 || [ "$(grep -o 'diverged at step [0-9]*' "$name.err")" = "diverged at step 1" ] ||
    fail "$name: no checkpoint of the last good state"
}

# Both stopped in their first step (the corners move faster than c_p relative to the
# centre): only the initial frame is written.
run_diverges fast -1e4
run_diverges slower -1e3
# Corner speed 0.94 c_p: a real compression (rho / rho0 up to 3.9) that the scheme then
# loses (main: the energy overflows at step 46, the frames before it at rho / rho0 =
# 1e171); stopped at its start, the last frame and checkpoint those of the step before.
run_diverges near -2.8e2 --set time.end=5e-3
step="$(sed -n 's/.*diverged at step \([0-9]*\) .*/\1/p' near.err)"
[ -n "$step" ] && [ "$step" -gt 1 ] || fail "near: not stopped after its first step: $(head -c 300 near.err)"
# The newest checkpoint is that of the last good step, the state of the last frame.
[ -n "$step" ] && [ -f "near/$(printf 'checkpoint_%010d.bin' $((step - 1)))" ] ||
  fail "near: no checkpoint of step $((step - 1)), the last good one: $(ls near | grep checkpoint)"

# A physical compression (corner speed 0.3 c_p) is not stopped.
"$tsph" run "$block" --quiet --out gentle --set 'initial.velocity_gradient=[-1e2,0.0,0.0,-1e2]' >gentle.out 2>gentle.err ||
  fail "gentle: exit $?: $(head -c 600 gentle.err)"

[ "$failures" -eq 0 ] && echo "all monitor checks passed"
exit "$failures"
