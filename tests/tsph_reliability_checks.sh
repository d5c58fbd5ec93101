#!/usr/bin/env bash
# Issue 15, the probes as checks (docs/reliability.md): damaged checkpoints, restarts
# with other physics, two runs into one directory, thread counts, blow-ups, probes,
# step-count overflow, memory limits, special particle files, SIGHUP, --restart DIR
# --out OTHER, messages. Each check names its item of the issue; each fails on main
# (3277c60).
#   tsph_reliability_checks.sh TSPH SOURCE_DIR
set -u
export OMP_WAIT_POLICY=PASSIVE  # threads do not spin against other jobs on few cores
tsph="$1"
src="$2"
bar="$src/tools/cases/bar.toml"
work="$(mktemp -d)"
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null; done
  rm -rf "$work"
}
trap cleanup EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
# expect STATUS PATTERN COMMAND...: the exit status and a pattern (grep -E) of stderr.
expect() {
  local status="$1" pattern="$2"
  shift 2
  "$@" >"$work/out.txt" 2>"$work/err.txt"
  local got=$?
  if [ "$got" -ne "$status" ]; then
    fail "$* exited $got, expected $status: $(head -c 600 "$work/err.txt")"
  elif [ -n "$pattern" ] && ! grep -Eq -- "$pattern" "$work/err.txt"; then
    fail "$*: stderr lacks /$pattern/: $(head -c 600 "$work/err.txt")"
  fi
}
last_frame() { sed -n 's/.*file="\([^"]*\)".*/\1/p' "$1/particles.pvd" | tail -1; }
# A listing with sizes and modification times: "nothing was written" compares two.
listing() { (cd "$1" && find . -type f -printf '%p %s %T@\n' | sort); }
cd "$work" || exit 1
ckpt=(--quiet --set output.checkpoint_every=50)

# --- 1. Checkpoint integrity and the physics of a restart --------------------------
"$tsph" run "$bar" "${ckpt[@]}" --out whole || fail "1: uninterrupted run"
reference="whole/$(last_frame whole)"
"$tsph" run "$bar" "${ckpt[@]}" --set time.end=5e-3 --set output.times=[3.75e-3] --out base || fail "1: run to 5 ms"
mapfile -t kept < <(ls base/checkpoint_*.bin | sort)
[ "${#kept[@]}" -eq 2 ] || fail "1: expected two checkpoints in base, found ${#kept[@]}"
newest="${kept[1]:-none}" older="${kept[0]:-none}"

# A flipped bit, 800 overwritten bytes, a truncated file: refused, naming file and check.
cp -r base flip && python3 - "flip/${newest#base/}" <<'EOF'
import sys; p = sys.argv[1]; b = bytearray(open(p, 'rb').read()); b[len(b) // 2] ^= 0x10; open(p, 'wb').write(b)
EOF
expect 2 "checkpoint 'flip/checkpoint_[0-9]+\.bin' is damaged: checksum check failed" \
  "$tsph" run "$bar" --quiet --restart "flip/${newest#base/}"
cp -r base over && dd if=/dev/urandom of="over/${newest#base/}" bs=1 seek=2000 count=800 conv=notrunc status=none
expect 2 "damaged: checksum check failed" "$tsph" run "$bar" --quiet --restart "over/${newest#base/}"
cp -r base trunc && truncate -s -100 "trunc/${newest#base/}"
expect 2 "trunc/checkpoint_[0-9]+\.bin' is damaged: size check failed" \
  "$tsph" run "$bar" --quiet --restart "trunc/${newest#base/}"
# --restart DIR falls back to the newest intact checkpoint, says so, and ends where the
# uninterrupted run ends, bit for bit.
expect 0 "falling back to trunc/${older#base/}" "$tsph" run "$bar" --quiet --restart trunc
cmp -s "$reference" "trunc/$(last_frame trunc)" || fail "1: the fallback restart differs from the uninterrupted run"
# Every checkpoint damaged: refused, nothing written.
cp -r base bad && truncate -s 30 bad/checkpoint_*.bin && before="$(listing bad)"
expect 2 "no intact checkpoint in bad" "$tsph" run "$bar" --quiet --restart bad
[ "$before" = "$(listing bad)" ] || fail "1: a refused restart (damaged checkpoints) wrote into bad"
# Format 1 (before issue 15): refused with a message that says why.
mkdir old && printf 'TSPHCKP1\001\000\000\000' >old/checkpoint_0000000001.bin
expect 2 "format 1" "$tsph" run "$bar" --quiet --restart old/checkpoint_0000000001.bin
# Other physics, by --set or by an edited case file: refused naming the key; nothing written.
cp -r base phys && before="$(listing phys)"
expect 2 "material\.E = 90000000 \(the checkpoint: 80000000\)" \
  "$tsph" run "$bar" --quiet --restart phys --set material.E=9e7
sed 's/^alpha = 0.6/alpha = 0.9/' "$bar" >edited.toml
expect 2 "method\.alpha = 0\.9 \(the checkpoint: 0\.6\)" "$tsph" run edited.toml --quiet --restart phys
[ "$before" = "$(listing phys)" ] || fail "1: a refused restart (other physics) wrote into phys"
# Run-control keys may change: a longer time.end continues.
expect 0 "" "$tsph" run "$bar" --quiet --restart phys --set time.end=7.5e-3

# --- 2. One run per output directory ---------------------------------------------
long=(--quiet --set time.end=100 --set output.times=[] --set output.probe_every=100000)
"$tsph" run "$bar" "${long[@]}" --out busy &
pids+=($!)
holder=$!
for _ in $(seq 1 200); do
  [ -s busy/.tsph-run.lock ] && break
  sleep 0.05
done
expect 2 "out = 'busy' is in use by another tsph run \(pid $holder\)" "$tsph" run "$bar" --quiet --out busy --overwrite
kill -9 "$holder" 2>/dev/null
wait "$holder" 2>/dev/null
# The lock died with the killed process.
expect 0 "" "$tsph" run "$bar" --quiet --out busy --overwrite
# Two runs started together: exactly one runs, the other is refused (exit 2).
for try in 1 2 3; do
  "$tsph" run "$bar" --quiet --out "race$try" 2>"race$try.a" &
  a=$!
  "$tsph" run "$bar" --quiet --out "race$try" 2>"race$try.b" &
  b=$!
  wait "$a"
  sa=$?
  wait "$b"
  sb=$?
  if ! { [ "$sa" -eq 0 ] && [ "$sb" -eq 2 ]; } && ! { [ "$sa" -eq 2 ] && [ "$sb" -eq 0 ]; }; then
    fail "2: two runs into race$try exited $sa and $sb, expected 0 and 2: $(cat "race$try.a" "race$try.b")"
  fi
done

# --- 3. Thread counts: one rule for the flag and the key ---------------------------
expect 2 "--threads = 100000 is invalid: must lie in \[0, [0-9]+\] .*hardware threads" \
  "$tsph" run "$bar" --quiet --out threads --threads 100000
[ -e threads ] && fail "3: a refused thread count created its output directory"
expect 2 "--threads = 50000 is invalid" "$tsph" check "$bar" --threads 50000
expect 2 "threads = 100000 is invalid: must lie in \[0, " "$tsph" check "$bar" --set threads=100000
expect 0 "" "$tsph" check "$bar" --threads 2

# --- 5. A CFL above 1 is refused, not run to a wrong "success" ----------------------
expect 2 "time\.cfl = 1\.05 is invalid" "$tsph" run "$bar" --quiet --out blowup --set time.cfl=1.05
sed 's/^cfl = 1.0 .*/dt = 5.25e-5/' "$bar" >dt_above.toml
expect 2 "exceeds the stability limit" "$tsph" run dt_above.toml --quiet --out blowup3
# Forced above the limit (time.force, the studies' switch): the blow-up ends with exit 3
# and a diagnosis naming the CFL, never exit 0 (tsph-bar --cfl 1.05 --force exited 0).
expect 3 "CFL = dt c_p / dx = 1.05 is above the scheme's stability limit" "$tsph" run "$bar" --quiet --out blowup4 \
  --set time.cfl=1.05 --set time.force=true

# --- 6. Probes -------------------------------------------------------------------
cat "$bar" >probes.toml
printf '\n[[output.probe]]\nname = "middle"\npoint = [0.25]\n' >>probes.toml
expect 2 "output\.probe\[1\]\.name = 'middle' is invalid: output\.probe\[0\] has the same name" \
  "$tsph" check probes.toml
cat "$bar" >far.toml
printf '\n[[output.probe]]\nname = "far"\nparticle = 100000\n' >>far.toml
expect 2 "output\.probe 'far': particle = 100000 is invalid: ids run from 0 to 100" "$tsph" check far.toml
expect 2 "output\.probe 'far': particle = 100000 is invalid" "$tsph" run far.toml --quiet --out far
[ -e far/case.toml ] && fail "6: a refused run left far/case.toml"
expect 0 "" "$tsph" run "$bar" --quiet --out far

# --- 7. Step-count overflow; dt above end ------------------------------------------
expect 2 "time\.end = 1e\+20 is invalid: at dt = 5e-05 s it needs 2e\+24 steps" \
  "$tsph" check "$bar" --set time.end=1e20
sed 's/^cfl = 1.0 .*/dt = 4e-5/; s/^end = 7.5e-3 .*/end = 1e-5/; s/^times = .*/times = []/' "$bar" >dt_end.toml
expect 2 "time\.dt = 4e-05 is invalid: it exceeds time\.end = 1e-05" "$tsph" check dt_end.toml

# --- 8. Memory: RLIMIT_AS is a limit; running out of memory leaves a summary ---------
# A sanitizer build (TSPH_SANITIZED=1, set by tests/CMakeLists.txt) maps terabytes of
# shadow memory at start and cannot run under ulimit -v: these checks run in Release.
if [ "${TSPH_SANITIZED:-0}" = 1 ]; then
  echo "8: skipped under a sanitizer (ulimit -v and the shadow memory do not mix)"
else
  big=(--set geometry.spacing=5e-7 --set time.end=1e-7 --set output.times=[])
  expect 2 "RLIMIT_AS" bash -c "ulimit -v 600000 && exec \"$tsph\" check \"$bar\" ${big[*]}"
  expect 1 "out of memory" bash -c "ulimit -v 600000 && exec \"$tsph\" run \"$bar\" ${big[*]} --quiet --out oom --ignore-limits"
  grep -q '"status": "out_of_memory"' oom/summary.json 2>/dev/null || fail "8: no summary.json with status out_of_memory"
fi

# --- 9. Special files as particle files ---------------------------------------------
cat >file.toml <<'EOF'
dimension = 2
[geometry]
spacing = 0.1
particle_file = "points.csv"
[material]
E = 8e7
rho = 2000.0
nu = 0.3
[method]
alpha = 1.2
[time]
end = 1e-3
cfl = 0.9
EOF
mkfifo fifo.csv
mkdir dir.csv
for special in /dev/urandom /dev/zero "$work/dir.csv" "$work/fifo.csv"; do
  expect 2 "geometry\.particle_file = '$special' is invalid: the file (is not a regular file|is a directory)" \
    timeout 20 "$tsph" check file.toml --set "geometry.particle_file=\"$special\""
done

# --- 10. SIGHUP stops the run as SIGINT does ----------------------------------------
"$tsph" run "$bar" "${long[@]}" --set output.every=2000 --out hup 2>hup.err &
pid=$!
pids+=("$pid")
for _ in $(seq 1 400); do
  [ -e hup/particles_000001.vtu ] && break
  sleep 0.02
done
kill -HUP "$pid"
wait "$pid"
[ $? -eq 1 ] || fail "10: SIGHUP: exit status is not 1"
grep -q '"status": "interrupted"' hup/summary.json 2>/dev/null || fail "10: SIGHUP: no summary.json (interrupted)"
ls hup/checkpoint_*.bin >/dev/null 2>&1 || fail "10: SIGHUP: no final checkpoint"

# --- 11. --restart DIR --out OTHER; old checkpoints pruned ---------------------------
expect 0 "" "$tsph" run "$bar" --quiet --restart "$older" --out other
for f in $(sed -n 's/.*file="\([^"]*\)".*/\1/p' other/particles.pvd); do
  [ -e "other/$f" ] || fail "11: other/particles.pvd lists $f, which is not in other"
done
cmp -s "$reference" "other/$(last_frame other)" || fail "11: the restart into other differs from the uninterrupted run"
cp -r base prune
expect 0 "" "$tsph" run "$bar" "${ckpt[@]}" --restart prune
n="$(ls prune/checkpoint_*.bin | wc -l)"
[ "$n" -eq 2 ] || fail "11: $n checkpoints in prune after a restart, expected the newest 2"

# --- 12. Messages -------------------------------------------------------------------
cp "$bar" unreadable.toml && chmod 000 unreadable.toml
if [ "$(id -u)" -eq 0 ] && command -v setpriv >/dev/null; then
  chmod 755 "$work"
  expect 2 "unreadable\.toml: case file cannot be read \(Permission denied\)" \
    setpriv --reuid=65534 --regid=65534 --clear-groups "$tsph" check unreadable.toml
elif [ "$(id -u)" -ne 0 ]; then
  expect 2 "case file cannot be read \(Permission denied\)" "$tsph" check unreadable.toml
fi
expect 2 "time\.cfl = 0 is invalid: must lie in \(0, 1\]: positive" "$tsph" check "$bar" --set time.cfl=0
sed 's/normal = \[-1.0\]/normal = [nan]/' "$bar" >nan.toml
expect 2 "e\.g\. normal = \[1\.0\]" "$tsph" check nan.toml
grep -q "normal = \[0\.0\]" "$work/err.txt" && fail "12: the NaN-normal message suggests [0.0]"
printf '0.0,0.0\n0.1,0.0\n' >points.csv
expect 2 "the header line is missing" "$tsph" check file.toml
sed 's/^region = { type = "half_space", point = \[0.0\], normal = \[-1.0\] }/region = []/' "$bar" >empty.toml
expect 2 "boundary\[0\]\.region = \[\] is invalid: must hold at least one region" "$tsph" check empty.toml
[ "$(grep -c 'error' "$work/err.txt")" -eq 1 ] || fail "12: an empty region list gives more than one message"

if [ "$failures" -ne 0 ]; then
  echo "$failures reliability check(s) failed"
  exit 1
fi
echo "all reliability checks passed"
