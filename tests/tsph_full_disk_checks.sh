#!/usr/bin/env bash
# tsph on a full disk: a 1 MiB tmpfs (mount -t tmpfs -o size=1m). A 2D run writing
# frames (210 KB each) and checkpoints (280 KB) is refused up front (status 2, the
# estimate and the free space); forced (--ignore-limits), it fills the disk part-way. It
# must stop with status 1 and a message naming the file and "No space left on device";
# the frames listed in particles.pvd are all there and read back; the newest checkpoint
# is intact (a restart from it, into another directory, runs to the end); no temporary
# file is left. Skipped (status 77) where mounting is not permitted (not root, or no
# tmpfs in this container).
#   tsph_full_disk_checks.sh TSPH SOURCE_DIR
set -u
tsph="$1"
src="$2"
cases="$src/tools/cases"
work="$(mktemp -d)"
disk="$work/disk"
mkdir -p "$disk"
cleanup() {
  mountpoint -q "$disk" && umount "$disk"
  rm -rf "$work"
}
trap cleanup EXIT
if ! mount -t tmpfs -o size=1m tsph-full-disk "$disk" 2>/dev/null; then
  echo "tsph_full_disk_checks: SKIPPED: cannot mount a tmpfs here (needs root)"
  exit 77
fi
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
beam=(--set time.end=0.004 --set output.every=10 --set output.checkpoint_every=20 --set damping.rest_velocity=0)

# Up front: the estimate (11 frames, 2 checkpoints: 3 MiB) exceeds the 1 MiB, refused.
text="$("$tsph" run "$cases/cantilever_2d.toml" --quiet --out "$disk/refused" "${beam[@]}" 2>&1)"
got=$?
if [ "$got" -ne 2 ] || ! grep -qE "the output needs about [23]\.[0-9]+ MiB of disk .* but 1 MiB are free under out = '$disk/refused'" <<<"$text"; then
  fail "up-front disk check -> status $got (want 2), output: $text"
fi
# Forced: the disk fills up part-way.
out="$disk/beam"
text="$("$tsph" run "$cases/cantilever_2d.toml" --quiet --out "$out" --ignore-limits "${beam[@]}" 2>&1)"
got=$?
if [ "$got" -ne 1 ] || ! grep -qE "tsph: stopped: cannot write '$out/[a-z_0-9]+\.(vtu|pvd|bin|csv)' \([a-z]+: No space left on device\)" <<<"$text"; then
  fail "full disk -> status $got (want 1), output: $text"
fi
ls "$out" | grep -qE '\.tmp$|\.partial$' && fail "temporary files left: $(ls "$out")"
# The frames listed in the .pvd: present and complete.
if ! /usr/bin/python3 -c "import sys; sys.path.insert(0, sys.argv[1]); import tsph_vtu
series = tsph_vtu.read_pvd(sys.argv[2])
assert len(series) >= 1, series
for t, p in series: assert tsph_vtu.read_vtu(p).points.shape[0] == 1111, p" "$src/tools" "$out/particles.pvd"; then
  fail "the frames kept on the full disk do not read back: $(ls -l "$out")"
fi
# The newest checkpoint restarts (elsewhere) and the run reaches its end.
checkpoint="$(ls "$out"/checkpoint_*.bin 2>/dev/null | tail -n 1)"
if [ -z "$checkpoint" ]; then
  fail "no checkpoint was kept: $(ls -l "$out")"
elif ! "$tsph" run "$cases/cantilever_2d.toml" --quiet --restart "$checkpoint" --out "$work/continued" "${beam[@]}" \
     >/dev/null 2>&1; then
  fail "the checkpoint kept on the full disk does not restart: $checkpoint"
fi
echo "tsph_full_disk_checks: $failures failures ($(ls "$out" | wc -l) files kept: $(ls "$out" | tr '\n' ' '))"
[ "$failures" -eq 0 ]
