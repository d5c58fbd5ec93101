#!/usr/bin/env bash
# Command-line contract of tsph-bar: bad input gives exit status 2 and one message
# naming the parameter, the value and the allowed range; good input gives 0.
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
expect 2 "cfl = 1.2 is invalid: must lie in \(0, 1\]" --cfl 1.2
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

checks=11
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
fi

echo "$((checks - failures)) passed, $failures failed"
[ "$failures" -eq 0 ]
