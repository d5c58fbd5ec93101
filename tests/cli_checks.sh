#!/usr/bin/env bash
# Command-line contract of the tsph subcommands beside run/check (tsph_cli_checks.sh):
# `tsph table1`, and `tsph run` on the shipped bar and cantilever cases (what tsph-bar
# and tsph-cantilever checked), `tsph spectrum`, `tsph converge`. Bad input gives exit
# status 2 and one message naming the key, the value and the allowed range; good input
# gives 0; a forced unstable run gives 3 and the diagnosis; an output file that cannot
# be written gives 1, names the file and loses nothing written before.
#   cli_checks.sh TSPH SOURCE_DIR
set -u
tsph="$1"
cases="$2/tools/cases"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
failures=0
checks=0

fail() {
  echo "FAIL: $*"
  failures=$((failures + 1))
}

expect() {  # expect STATUS REGEX ARGS...
  local status="$1" pattern="$2"
  shift 2
  local text
  checks=$((checks + 1))
  rm -rf "$out/run"
  text="$("$tsph" "$@" 2>&1)"
  local got=$?
  if [ "$got" -ne "$status" ] || ! grep -qE -- "$pattern" <<<"$text"; then
    fail "tsph $* -> status $got (want $status), output: $text (want /$pattern/)"
  fi
}

bar=(run "$cases/bar.toml" --quiet --out "$out/run")
expect 2 "method.alpha = -1 is invalid: must lie in \(0.5, 4\]" "${bar[@]}" --set method.alpha=-1
expect 2 "time.cfl = 1.2 is invalid: must lie in \(0, 1\].*time.force = true" "${bar[@]}" --set time.cfl=1.2
expect 3 "diverged: solver: the solution diverged at step [0-9]+ \(t = .* s\): real particle [0-9]+ at \(.*\) .*likely cause: the time step: CFL = dt c_p / dx = 1.5" \
  "${bar[@]}" --set time.cfl=1.5 --set time.force=true
expect 2 "method.kernel = 'gauss' is invalid: must be one of: cubic_spline, wendland_c2, quintic_spline" "${bar[@]}" --set method.kernel=gauss
expect 2 "material.E = 0 is invalid: must be positive" "${bar[@]}" --set material.E=0
expect 2 "material.rho = -5 is invalid" "${bar[@]}" --set material.rho=-5
expect 2 "output.times = .* is invalid: each must lie in \(0, time.end = 0.005\]" "${bar[@]}" --set time.end=0.005 \
  --set "output.times=[0.001, 0.009]"
expect 2 "The following argument was not expected|not expected" "${bar[@]}" --no-such-option
expect 2 "out = .* cannot be created" run "$cases/bar.toml" --quiet --out /proc/forbidden/dir

# The seed's Table 1: the three alpha, our errors beside the paper's, the files that
# tools/plot_table1.py and tools/plot_bar.py read.
expect 0 "^ +0.6 +0.012 +2 +[0-9.e+-]+ +[0-9.e+-]+ +1e-3" table1 --out "$out/table1"
for f in table1.csv summary.json alpha0.6/summary.json alpha1.6/particles.pvd profile_alpha1.2_t7.500000ms.csv; do
  [ -s "$out/table1/$f" ] || fail "tsph table1 did not write $f"
done
checks=$((checks + 1))
grep -q '"schema": "tsph.summary/1"' "$out/table1/summary.json" && grep -q '"command": "table1"' "$out/table1/summary.json" &&
  grep -q '"schema": "tsph.summary/1"' "$out/table1/alpha1.2/summary.json" ||
  fail "table1 summaries lack the schema: $(cat "$out/table1/summary.json")"
[ "$(head -1 "$out/table1/table1.csv")" = "alpha,support_radius,error_percent_3p75ms,error_percent_7p5ms,paper_percent" ] ||
  fail "table1.csv header: $(head -1 "$out/table1/table1.csv")"
expect 2 "method.kernel = 'gauss' is invalid" table1 --out "$out/table1" --set method.kernel=gauss

# Output failure: the file-size limit (ulimit -f, SIGXFSZ ignored) makes writes fail
# with EFBIG, as a full disk does with ENOSPC. The files of an earlier run must stay.
# Not under ThreadSanitizer, whose runtime faults (SIGBUS) under a file-size limit.
if [ -z "${TSAN_OPTIONS:-}" ]; then
  checks=$((checks + 1))
  mkdir -p "$out/full"
  echo "earlier run" >"$out/full/table1.csv"
  echo "earlier profile" >"$out/full/profile_alpha0.6_t3.750000ms.csv"
  text="$( (trap '' XFSZ; ulimit -f 4; exec "$tsph" table1 --out "$out/full") 2>&1)"
  got=$?
  if [ "$got" -ne 1 ] || ! grep -qE "cannot write '.*' \((write|close): File too large\)" <<<"$text" ||
     [ "$(cat "$out/full/table1.csv")" != "earlier run" ] ||
     [ "$(cat "$out/full/profile_alpha0.6_t3.750000ms.csv")" != "earlier profile" ]; then
    fail "output failure -> status $got (want 1), output: $text; directory: $(ls "$out/full")"
  fi
fi

# The cantilever case: bad input, exit status 2.
beam=(run "$cases/cantilever_2d.toml" --quiet --out "$out/run")
expect 2 "material.nu = 0.5 is invalid: must lie in \(-1, 0.5\)" "${beam[@]}" --set material.nu=0.5
expect 2 "needs a real particle on the beam axis" "${beam[@]}" --set geometry.spacing=0.02
expect 2 "material.E = -1 is invalid" "${beam[@]}" --set material.E=-1
expect 2 "material.plane = 'membrane' is invalid: must be one of: stress, strain" "${beam[@]}" --set material.plane=membrane
expect 2 "time.cfl = 1.5 is invalid: must lie in \(0, 1\]" "${beam[@]}" --set time.cfl=1.5
expect 2 "method.free_edge_uniaxial = true is invalid: applies to dimension = 3 only" "${beam[@]}" \
  --set method.free_edge_uniaxial=true
expect 2 "method.velocity_wall = 'wall-gradient' is invalid: must be one of: automatic, characteristics, wall_gradient" "${beam[@]}" \
  --set method.velocity_wall=wall-gradient
# A forced unstable CFL: exit status 3 and the diagnosis within a few steps; the last
# good state (the initial frame) is written and summary.json says so.
expect 3 "diverged at step [0-9]+ .*real particle [0-9]+ at \(.*, .*\).*likely cause: the time step: CFL" "${beam[@]}" \
  --set geometry.spacing=0.05 --set time.cfl=1.5 --set time.force=true
checks=$((checks + 1))
grep -q '"status": "diverged"' "$out/run/summary.json" 2>/dev/null && grep -q '"message": ".*diverged at step' "$out/run/summary.json" &&
  [ -s "$out/run/particles_000000.vtu" ] ||
  fail "a diverged cantilever run should keep its last good state: $(ls "$out/run"); $(cat "$out/run/summary.json" 2>&1)"

# tsph spectrum on the 21 x 3 beam (441 unknowns), and refused on the 1D bar.
expect 0 "spectral radius [0-9.]+" spectrum "$cases/cantilever_2d.toml" --set geometry.spacing=0.05 --out "$out/spectrum"
checks=$((checks + 1))
[ "$(wc -l <"$out/spectrum/eigenvalues.csv")" -eq 442 ] && [ -s "$out/spectrum/fixed_point.csv" ] ||
  fail "tsph spectrum files: $(ls "$out/spectrum")"
# --write-map: G itself (441 x 441 float64) and what each of its rows is.
expect 0 "spectral radius [0-9.]+" spectrum "$cases/cantilever_2d.toml" --set geometry.spacing=0.05 --write-map \
  --out "$out/spectrum_map"
checks=$((checks + 1))
[ "$(wc -c <"$out/spectrum_map/map.f64")" -eq $((441 * 441 * 8)) ] && [ "$(wc -l <"$out/spectrum_map/map_rows.csv")" -eq 442 ] &&
  cmp -s "$out/spectrum/eigenvalues.csv" "$out/spectrum_map/eigenvalues.csv" ||
  fail "tsph spectrum --write-map files: $(ls -l "$out/spectrum_map")"
# Undamped, the beam's first bending mode is the slowest oscillation: 0.389 s at 21 x 3
# (Euler-Bernoulli 0.3095 s; 3 rows are coarse), with its growth per step and period.
expect 0 "^  period 3\.[0-9]{4}e-01 s \([0-9]+ steps\)  \|lambda\| - 1 = -[0-9.]+e-0[0-9] per step" spectrum \
  "$cases/cantilever_2d.toml" --set geometry.spacing=0.05 --set damping.coefficient=0 --out "$out/spectrum_undamped"
expect 2 "dimension 2 or 3" spectrum "$cases/bar.toml" --out "$out/spectrum"

# tsph converge: the bar at alpha 1.2 and two spacings; the observed rates printed.
expect 0 "velocity_x_l2 %.*rate" converge "$cases/bar.toml" --set method.alpha=1.2 --sweep geometry.spacing=0.02,0.01 \
  --out "$out/converge"
checks=$((checks + 1))
grep -q '"command": "converge"' "$out/converge/summary.json" && [ -s "$out/converge/spacing_0.01/summary.json" ] &&
  [ "$(wc -l <"$out/converge/converge.csv")" -eq 3 ] || fail "tsph converge files: $(ls "$out/converge")"
expect 2 "write --sweep KEY=V1,V2" converge "$cases/bar.toml" --sweep method.alpha --out "$out/converge"
expect 2 "method.alpha = 9 is invalid" converge "$cases/bar.toml" --sweep method.alpha=0.6,9 --out "$out/converge"

# --help texts carry no measured figures (they date; docs/ holds them).
for sub in run check table1 spectrum converge; do
  checks=$((checks + 1))
  text="$("$tsph" "$sub" --help 2>&1)"
  if grep -qE "[0-9] ?%" <<<"$text"; then fail "tsph $sub --help quotes a figure: $(grep -E "[0-9] ?%" <<<"$text")"; fi
done

echo "$((checks - failures)) passed, $failures failed"
[ "$failures" -eq 0 ]
