#!/usr/bin/env bash
# Checkpoint and restart: (1) a run continued from a periodic checkpoint ends bit for bit
# where the uninterrupted run ends; (2) SIGINT during a run leaves its last frame, a
# readable checkpoint and summary.json (exit status 1), and continuing from that
# checkpoint again ends bit for bit where the uninterrupted run ends.
#   tsph_restart_checks.sh TSPH SOURCE_DIR
set -u
export OMP_WAIT_POLICY=PASSIVE  # threads do not spin against other jobs on few cores
tsph="$1"
src="$2"
case_file="$src/tools/cases/cantilever_2d.toml"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
last_frame() { sed -n 's/.*file="\([^"]*\)".*/\1/p' "$1/particles.pvd" | tail -1; }
# Damping, ramp, hourglass filter and probes on; no rest criterion, so the run ends at time.end.
args=(--quiet --set time.end=0.06 --set output.every=200 --set damping.rest_velocity=0)

"$tsph" run "$case_file" "${args[@]}" --out "$work/whole" --threads 2 || fail "uninterrupted run"
reference="$work/whole/$(last_frame "$work/whole")"

# (1) Periodic checkpoints; continue from the first one in another directory, 1 thread.
"$tsph" run "$case_file" "${args[@]}" --set output.checkpoint_every=500 --out "$work/periodic" ||
  fail "run with checkpoints"
first="$(ls "$work/periodic"/checkpoint_*.bin | head -1)"
[ -n "$first" ] || fail "no checkpoint written"
"$tsph" run "$case_file" "${args[@]}" --restart "$first" --out "$work/continued" --threads 1 ||
  fail "restart from $first"
cmp -s "$reference" "$work/continued/$(last_frame "$work/continued")" ||
  fail "restart from a periodic checkpoint differs from the uninterrupted run"

# (2) SIGINT once the first frames are out; then continue in place.
"$tsph" run "$case_file" "${args[@]}" --out "$work/stopped" --threads 1 &
pid=$!
for _ in $(seq 1 400); do
  [ -e "$work/stopped/particles_000002.vtu" ] && break
  sleep 0.02
done
kill -INT "$pid" 2>/dev/null
wait "$pid"
status=$?
if [ "$status" -eq 0 ]; then
  echo "note: the run ended before SIGINT arrived; the interruption was not tested"
else
  [ "$status" -eq 1 ] || fail "SIGINT: exit status $status, want 1"
  grep -q '"status": "interrupted"' "$work/stopped/summary.json" || fail "SIGINT: summary.json not marked interrupted"
  ls "$work/stopped"/checkpoint_*.bin >/dev/null 2>&1 || fail "SIGINT: no checkpoint"
  /usr/bin/python3 "$src/tests/check_vtu.py" "$work/stopped" 2 >/dev/null || fail "SIGINT: output does not read back"
  "$tsph" run "$case_file" "${args[@]}" --restart "$work/stopped" --threads 2 || fail "continuing after SIGINT"
  cmp -s "$reference" "$work/stopped/$(last_frame "$work/stopped")" ||
    fail "continuing after SIGINT differs from the uninterrupted run"
  /usr/bin/python3 "$src/tests/check_vtu.py" "$work/stopped" 2 >/dev/null || fail "continued output does not read back"
fi
# A file that is not a checkpoint, and a checkpoint of another case.
echo junk >"$work/junk.bin"
"$tsph" run "$case_file" "${args[@]}" --restart "$work/junk.bin" --out "$work/j" 2>"$work/err"
[ $? -eq 2 ] || fail "junk checkpoint: exit status not 2"
grep -q "is not a tsph checkpoint" "$work/err" || fail "junk checkpoint message: $(cat "$work/err")"
"$tsph" run "$src/tools/cases/bar.toml" --quiet --restart "$first" --out "$work/k" 2>"$work/err"
[ $? -eq 2 ] && grep -q "1D" "$work/err" || fail "checkpoint of another case: $(cat "$work/err")"


# (3) The adaptive time step (time.adaptive, the Taylor bar's first microseconds, J2, the
# impact face flattening): a restart takes the steps the uninterrupted run took.
bar="$src/tools/cases/taylor_bar_3d.toml"
bar_args=(--quiet --set time.end=3e-6 --set 'output.times=[1e-6, 2e-6, 3e-6]')
"$tsph" run "$bar" "${bar_args[@]}" --out "$work/bar_whole" --threads 2 || fail "Taylor bar run"
"$tsph" run "$bar" "${bar_args[@]}" --set output.checkpoint_every=10 --out "$work/bar_periodic" --threads 2 ||
  fail "Taylor bar run with checkpoints"
bar_first="$(ls "$work/bar_periodic"/checkpoint_*.bin | head -1)"
[ -n "$bar_first" ] || fail "Taylor bar: no checkpoint written"
"$tsph" run "$bar" "${bar_args[@]}" --restart "$bar_first" --out "$work/bar_continued" --threads 1 ||
  fail "Taylor bar restart from $bar_first"
cmp -s "$work/bar_whole/$(last_frame "$work/bar_whole")" "$work/bar_continued/$(last_frame "$work/bar_continued")" ||
  fail "Taylor bar (adaptive step): the restart differs from the uninterrupted run"
grep -q '"steps": ' "$work/bar_whole/summary.json" && [ "$(grep -o '"steps": [0-9]*' "$work/bar_whole/summary.json")" = \
  "$(grep -o '"steps": [0-9]*' "$work/bar_continued/summary.json")" ] || fail "Taylor bar: step counts differ"

echo "tsph_restart_checks: $failures failures"
[ "$failures" -eq 0 ]
