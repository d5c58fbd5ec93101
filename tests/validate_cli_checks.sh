#!/usr/bin/env bash
# tsph validate on bad input and --list (issue 14): an unknown case name exits 2 and
# lists the valid names; --list exits 0; a bad --cases directory exits 2.
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
exit $fail
