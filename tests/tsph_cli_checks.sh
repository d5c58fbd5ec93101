#!/usr/bin/env bash
# Command-line contract of tsph: exit status (0 ok, 2 bad input, 3 diverged / not at
# rest, 1 other) and one clear message per bad input; nothing on disk is overwritten
# without --overwrite; the VTU output reads back (tests/check_vtu.py).
#   tsph_cli_checks.sh TSPH SOURCE_DIR
set -u
tsph="$1"
src="$2"
cases="$src/tools/cases"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
failures=0
checks=0

expect() {  # expect STATUS REGEX ARGS...
  local status="$1" pattern="$2"
  shift 2
  local text got
  text="$("$tsph" "$@" 2>&1)"
  got=$?
  checks=$((checks + 1))
  if [ "$got" -ne "$status" ] || ! grep -qE -- "$pattern" <<<"$text"; then
    echo "FAIL: tsph $* -> status $got (want $status), output: $text (want /$pattern/)"
    failures=$((failures + 1))
  fi
}

# Case files with one fault each (copies of the bar).
bad() {  # bad NAME SED-ARGS...: writes $work/NAME.toml
  local name="$1"
  shift
  sed "$@" "$cases/bar.toml" >"$work/$name.toml"
}
bad syntax -e 's/^\[material\]/[material/'
bad unknown -e 's/^alpha = 0.6/alhpa = 0.6/'
bad type -e 's/^E = 8e7/E = "8e7"/'
bad range -e 's/^cfl = 1.0 /cfl = 1.5 /'
bad missing -e '/^rho = /d'
bad region -e 's/point = \[0.0\], normal = \[-1.0\]/point = [-5.0], normal = [-1.0]/'
bad nofile -e 's/^box = .*/particle_file = "none.csv"/' -e '/^\[exact\]/,$d'
bad badfile -e 's/^box = .*/particle_file = "bad.csv"/' -e '/^\[exact\]/,$d'
bad dt -e 's/^cfl = 1.0 .*/dt = 2e-4/'
printf 'x\n0.0\n0.01\nnan\n' >"$work/bad.csv"

expect 0 "^tsph [0-9]+\.[0-9]+\.[0-9]+" --version
expect 0 "Subcommands:" --help
expect 0 "--overwrite" run --help
expect 0 "validate" check --help
expect 2 "A subcommand is required|requires" 
expect 2 "syntax\.toml:[0-9]+:[0-9]+: TOML syntax error" check "$work/syntax.toml"
expect 2 "unknown\.toml:[0-9]+:1: unknown key method\.alhpa: did you mean method\.alpha\?" check "$work/unknown.toml"
expect 2 "type\.toml:[0-9]+:[0-9]+: material\.E = '8e7' is invalid: must be a number" check "$work/type.toml"
expect 2 "range\.toml:[0-9]+:[0-9]+: time\.cfl = 1\.5 is invalid: must lie in \(0, 1\]" check "$work/range.toml"
expect 2 "missing required key material\.rho in \[material\]: add e\.g\. rho = 2000" check "$work/missing.toml"
expect 2 "boundary\[0\] 'left end': region 'left end' selects no particle" check "$work/region.toml"
expect 2 "particle file '.*none\.csv' cannot be opened" check "$work/nofile.toml"
expect 2 "bad\.csv.*line 4" check "$work/badfile.toml"
expect 2 "case file cannot be read \(no such file\)" check "$work/absent.toml"
expect 2 "material\.E = -1 is invalid: must be positive" check "$cases/bar.toml" --set material.E=-1
expect 2 "unknown key method\.kernal: did you mean method\.kernel\?" check "$cases/bar.toml" --set method.kernal=gauss
expect 2 "method\.kernel = 'gauss' is invalid: must be one of: cubic_spline, wendland_c2, quintic_spline" \
  check "$cases/bar.toml" --set method.kernel=gauss
expect 0 "101 real, 100 virtual" check "$cases/bar.toml"
expect 0 "1111 real, 1000 virtual" check "$cases/cantilever_2d.toml"
expect 0 "plane strain" check "$cases/cantilever_2d.toml" --set material.plane=strain
expect 0 "41 x 5 x 5|1025 real" check "$cases/cantilever_3d.toml"

# Output directory: cannot be created / written; an existing non-empty one is kept.
expect 2 "out = '/proc/forbidden/dir' cannot be created" run "$cases/bar.toml" --quiet --out /proc/forbidden/dir
mkdir -p "$work/kept" && echo precious >"$work/kept/notes.txt"
expect 2 "out = '.*kept' is not empty: .*--overwrite" run "$cases/bar.toml" --quiet --out "$work/kept"
[ "$(cat "$work/kept/notes.txt")" = precious ] && [ ! -e "$work/kept/summary.json" ] ||
  { echo "FAIL: a refused run touched the output directory"; failures=$((failures + 1)); }
expect 0 "" run "$cases/bar.toml" --quiet --out "$work/kept" --overwrite
[ "$(cat "$work/kept/notes.txt" 2>/dev/null)" = precious ] ||
  { echo "FAIL: --overwrite removed a file tsph did not write"; failures=$((failures + 1)); }

# A real run: 1D bar, output read back and compared with the exact solution.
expect 0 "finished at t = 0.0075 s after 150 steps" run "$cases/bar.toml" --out "$work/bar" --threads 1
if ! /usr/bin/python3 "$src/tests/check_vtu.py" "$work/bar" 1 --exact-velocity; then
  echo "FAIL: the bar's VTU output does not read back"; failures=$((failures + 1))
fi
grep -q '"velocity_x_l2_percent"' "$work/bar/summary.json" && grep -q '"version"' "$work/bar/summary.json" ||
  { echo "FAIL: summary.json lacks errors or version"; failures=$((failures + 1)); }
[ "$(grep -vc '^#' "$work/bar/probe_middle.csv")" -eq 152 ] ||
  { echo "FAIL: probe_middle.csv should hold a header and 151 rows"; failures=$((failures + 1)); }
# 2D, short: structure of the 2D output, virtual particles included.
expect 0 "" run "$cases/cantilever_2d.toml" --quiet --out "$work/beam" \
  --set time.end=0.002 --set output.every=10 --set output.virtual=true --set damping.rest_velocity=0
if ! /usr/bin/python3 "$src/tests/check_vtu.py" "$work/beam" 2; then
  echo "FAIL: the cantilever's VTU output does not read back"; failures=$((failures + 1))
fi
[ -f "$work/beam/virtual.pvd" ] || { echo "FAIL: no virtual.pvd"; failures=$((failures + 1)); }
# Not at rest by the end time: exit status 3.
expect 3 "did not come to rest" run "$cases/cantilever_2d.toml" --quiet --out "$work/rest" --set time.end=0.002
# Diverged (a body force that overflows the stress): exit status 3, summary marked.
expect 3 "diverged: solver: the solution diverged at step" run "$cases/bar.toml" --quiet --out "$work/diverged" \
  --set 'method.body_force=[1e308]'
grep -q '"status": "diverged"' "$work/diverged/summary.json" 2>/dev/null ||
  { echo "FAIL: summary.json of a diverged run"; failures=$((failures + 1)); }
expect 2 "time\.dt = 0\.0002 is invalid: exceeds the stability limit" check "$work/dt.toml"

echo "tsph_cli_checks: $checks checks, $failures failures"
[ "$failures" -eq 0 ]
