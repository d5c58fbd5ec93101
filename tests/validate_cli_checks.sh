#!/usr/bin/env bash
# tsph validate on bad input and --list (issue 14): an unknown case name exits 2 and
# lists the valid names; --list exits 0; a bad --cases directory exits 2; --set applies
# a key to every case file (after the case's own overrides; a case name after it stays a
# name) and a key the case file does not have exits 2 naming it; --jobs 2 (cases at a time)
# gives the rows of --jobs 1, in the listed order.
#   tests/validate_cli_checks.sh build/tools/tsph OUTDIR
set -u
tsph=$1
out=$2
rm -rf "$out" && mkdir -p "$out"
fail=0
check() {  # check NAME EXPECTED_STATUS PATTERN -- command...
  local name=$1 expected=$2 pattern=$3
  shift 4
  "$@" >"$out/stdout" 2>"$out/stderr"
  local status=$?
  if [[ $status -ne $expected ]] || ! grep -q -- "$pattern" "$out/stdout" "$out/stderr"; then
    echo "FAIL: $name: status $status (expected $expected), pattern '$pattern'"
    cat "$out/stdout" "$out/stderr"
    fail=1
  else
    echo "ok: $name"
  fi
}
check "unknown name lists the cases" 2 "homogeneous_shear_2d" -- "$tsph" validate no_such_case --out "$out/v"
check "unknown name is named" 2 "no_such_case" -- "$tsph" validate no_such_case --out "$out/v"
check "--list" 0 "rotation_2d_alpha0.6" -- "$tsph" validate --list
check "bad --cases" 2 "--cases" -- "$tsph" validate homogeneous_shear_2d --cases "$out/none" --out "$out/v"
check "--set: an unknown key exits 2 and is named" 2 "unknown key method.nonsense" -- \
  "$tsph" validate --set method.nonsense=1 homogeneous_shear_2d --quick --out "$out/s1"
check "--set without '=' exits 2" 2 "write --set key=value" -- \
  "$tsph" validate --set homogeneous_shear_2d --quick --out "$out/s0"
check "--set: applied to the case" 0 "5 checks passed" -- \
  "$tsph" validate --set method.hourglass=0.01 homogeneous_shear_2d --quick --threads 1 --out "$out/s2"
if ! grep -q '"hourglass": 0.01,' "$out/s2/homogeneous_shear_2d/run/summary.json"; then
  echo "FAIL: --set: the run's summary.json does not resolve method.hourglass = 0.01"
  fail=1
else
  echo "ok: --set: the run resolved method.hourglass = 0.01"
fi
check "--jobs 2" 0 "2 at a time, 1 thread each" -- \
  "$tsph" validate homogeneous_stretch --quick --jobs 2 --threads 1 --out "$out/j2"
check "--jobs 1" 0 "checks passed" -- "$tsph" validate homogeneous_stretch --quick --jobs 1 --threads 1 --out "$out/j1"
if ! diff <(grep -E '"name"|"figure"' "$out/j1/validate.json" | sed 's/"wall_seconds": [0-9.]*//') \
          <(grep -E '"name"|"figure"' "$out/j2/validate.json" | sed 's/"wall_seconds": [0-9.]*//'); then
  echo "FAIL: --jobs 2: validate.json differs from --jobs 1 (the cases' order or their values)"
  fail=1
elif [[ $(grep -c '"figure"' "$out/j2/validate.json") -ne 6 ]]; then
  echo "FAIL: --jobs 2: expected the 6 checks of homogeneous_stretch_3d and _2d"
  fail=1
else
  echo "ok: --jobs 2: the rows of --jobs 1, in the listed order"
fi
exit $fail
