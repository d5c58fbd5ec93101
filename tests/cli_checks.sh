#!/usr/bin/env bash
# Command-line contract of tsph-bar: bad input gives exit status 2 and one message
# naming the parameter, the value and the allowed range; good input gives 0; a forced
# unstable run gives 3 and the diagnosis; an output file that cannot be written gives 1,
# names the file and loses nothing written before.
set -u
bar="$1"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
failures=0

expect() {  # expect STATUS REGEX ARGS...
  local status="$1" pattern="$2"
  shift 2
  local text
  local args=(--quiet "$@")
  [[ " $* " == *" --out "* ]] || args=(--out "$out/run" "${args[@]}")
  text="$("$bar" "${args[@]}" 2>&1)"
  local got=$?
  if [ "$got" -ne "$status" ] || ! grep -qE -- "$pattern" <<<"$text"; then
    echo "FAIL: tsph-bar $* -> status $got (want $status), output: $text (want /$pattern/)"
    failures=$((failures + 1))
  fi
}

expect 2 "alpha = -1 is invalid: must lie in \(0.5, 4\]" --alpha -1
expect 2 "cfl = 1.2 is invalid: must lie in \(0, 1\].*force" --cfl 1.2
expect 3 "stopped: solver: the solution diverged at step [0-9]+ \(t = .* s\): real particle [0-9]+ at \(.*\) .*likely cause: the time step: CFL = dt c_p / dx = 1.5" --cfl 1.5 --force
expect 2 "kernel = 'gauss' is invalid: must be one of: cubic_spline, quintic_spline, wendland_c2" --kernel gauss
expect 2 "young_modulus = 0 is invalid: must be a positive" --E 0
expect 2 "density = -5 is invalid" --rho -5
expect 2 "dx = -0.01 is invalid|length = -1 is invalid" --length -1
expect 2 "output_times = 0.009 is invalid: each must lie in \(0, end_time = 0.005\]" --times 0.001,0.009 --end-time 0.005
expect 2 "particles = 2 is invalid" --particles 2
expect 2 "The following argument was not expected|not expected" --no-such-option
expect 2 "out = .* cannot be created" --out /proc/forbidden/dir
expect 0 "" --times 0.00375
[ -f "$out/run/summary.json" ] || { echo "FAIL: no summary.json"; failures=$((failures + 1)); }
grep -q '"velocity_l2_error_percent"' "$out/run/summary.json" 2>/dev/null ||
  { echo "FAIL: summary.json lacks the errors"; failures=$((failures + 1)); }

checks=12

# Output failure: the file-size limit (ulimit -f, SIGXFSZ ignored) makes writes fail
# with EFBIG, as a full disk does with ENOSPC. The files of an earlier run must stay.
# Not under ThreadSanitizer, whose runtime faults (SIGBUS) under a file-size limit.
if [ -z "${TSAN_OPTIONS:-}" ]; then
checks=$((checks + 1))
mkdir -p "$out/full"
echo "earlier run" >"$out/full/summary.json"
echo "earlier profile" >"$out/full/profile_t3.750000ms.csv"
text="$( (trap '' XFSZ; ulimit -f 4; exec "$bar" --quiet --out "$out/full" --times 0.00375) 2>&1)"
got=$?
if [ "$got" -ne 1 ] || ! grep -qE "stopped: cannot write '.*profile_t3.750000ms.csv' \(write: File too large\)" <<<"$text" ||
   [ "$(cat "$out/full/summary.json")" != "earlier run" ] ||
   [ "$(cat "$out/full/profile_t3.750000ms.csv")" != "earlier profile" ] ||
   ls "$out/full" | grep -q partial; then
  echo "FAIL: output failure -> status $got (want 1), output: $text; directory: $(ls "$out/full")"
  failures=$((failures + 1))
fi
fi
# tsph-cantilever (second argument): bad input only, exit status 2.
cantilever="${2:-}"
if [ -n "$cantilever" ]; then
  expect_cantilever() {  # expect_cantilever REGEX ARGS...
    local pattern="$1"
    shift
    local text
    text="$("$cantilever" --out "$out/cantilever" --quiet "$@" 2>&1)"
    local got=$?
    checks=$((checks + 1))
    if [ "$got" -ne 2 ] || ! grep -qE -- "$pattern" <<<"$text"; then
      echo "FAIL: tsph-cantilever $* -> status $got (want 2), output: $text (want /$pattern/)"
      failures=$((failures + 1))
    fi
  }
  expect_cantilever "poisson_ratio = 0.5 is invalid: must lie in \(-1, 0.5\)" --nu 0.5
  expect_cantilever "nodes_y = 6 is invalid: must be odd" --nx 51
  expect_cantilever "young_modulus = -1 is invalid" --E -1
  expect_cantilever "plane: .*not in" --plane membrane
  expect_cantilever "cfl = 1.5 is invalid: must lie in \(0, 1\].*force" --cfl 1.5
  expect_cantilever "free_edge_uniaxial = true is invalid: applies to the edges of the 3D beam only" --free-edge-uniaxial
  expect_cantilever "alpha = 2.5 is invalid: must lie in \(0.5, 1.9\] for the cubic_spline kernel" --alpha 2.5
  expect_cantilever "alpha = 2.5 is invalid: must lie in \(0.5, 2.4\] for the quintic_spline kernel" --alpha 2.5 \
    --kernel quintic_spline --nx 21
  # A forced unstable CFL: exit status 3 and the diagnosis, within a few steps; the
  # last good state (here the initial one) is written, summary.json says so.
  checks=$((checks + 1))
  rm -rf "$out/cantilever"
  text="$("$cantilever" --out "$out/cantilever" --quiet --nx 21 --cfl 1.5 --force 2>&1)"
  got=$?
  if [ "$got" -ne 3 ] || ! grep -qE "diverged at step [0-9]+ .*real particle [0-9]+ at \(.*, .*\).*likely cause: the time step: CFL" <<<"$text"; then
    echo "FAIL: tsph-cantilever --cfl 1.5 --force -> status $got (want 3), output: $text"
    failures=$((failures + 1))
  fi
  checks=$((checks + 1))
  if ! grep -q '"status": "diverged", "message": ".*diverged at step' "$out/cantilever/summary.json" 2>/dev/null ||
     ! grep -q '"time": 0.000000' "$out/cantilever/summary.json" ||
     [ "$(wc -l <"$out/cantilever/particles.csv")" -ne $((21 * 3 + 1)) ] || [ ! -s "$out/cantilever/axis.csv" ]; then
    echo "FAIL: a diverged tsph-cantilever run should keep its last good state: $(ls "$out/cantilever"); $(cat "$out/cantilever/summary.json" 2>&1)"
    failures=$((failures + 1))
  fi
fi

echo "$((checks - failures)) passed, $failures failed"
[ "$failures" -eq 0 ]
