#!/usr/bin/env bash
# Convergence study of the 2D cantilever (issue 3): runs tsph-cantilever at successive
# halvings of the spacing and prints tip and axis errors with the observed rate
# log2(e(2 dx) / e(dx)). Not part of the test suite (the finest run takes minutes).
#
#   tools/cantilever_convergence.sh                       # nx = 41 81 161 (dx = L/40, /80, /160)
#   NX="41 61 81 101" tools/cantilever_convergence.sh --plane strain
#   NX="41 81" tools/cantilever_convergence.sh --clamp characteristics --hourglass-stiffness 0 \
#       --no-surface-extrapolation                        # the 2D defaults before 2026-11-23 (creep)
#
# Extra arguments go to every tsph-cantilever run. Outputs: out/cantilever-convergence/nx<N>/.
# A run that does not come to rest (exit status 3) is reported as such, with its error
# at the time limit; its rate is then meaningless and printed as '-'.
set -uo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/tools/build.sh" --target tsph-cantilever || exit 1
exe="${TSPH_BUILD_DIR:-$root/build}/tools/tsph-cantilever"
out="$root/out/cantilever-convergence"
mkdir -p "$out"
for nx in ${NX:-41 81 161}; do
  "$exe" --nx "$nx" --quiet --out "$out/nx$nx" "$@"
  status=$?
  if [ "$status" -ne 0 ] && [ "$status" -ne 3 ]; then
    echo "cantilever_convergence: tsph-cantilever --nx $nx failed (exit status $status)" >&2
    exit "$status"
  fi
done
/usr/bin/python3 - "$out" ${NX:-41 81 161} <<'EOF'
import json, math, sys
out, sizes = sys.argv[1], sys.argv[2:]
rows = [json.load(open(f"{out}/nx{n}/summary.json")) for n in sizes]
print(f"{'nodes':>10} {'dx (m)':>9} {'rest':>5} {'t (s)':>6} {'tip err %':>10} {'rate':>5} "
      f"{'axis L2 %':>10} {'rate':>5} {'wall (s)':>9}")
prev = None
for r in rows:
    def rate(key):
        if prev is None or not (prev["converged"] and r["converged"]) or r[key] <= 0:
            return "-"
        return f"{math.log(prev[key] / r[key]) / math.log(prev['dx'] / r['dx']):.2f}"
    nodes = f"{r['nodes'][0]} x {r['nodes'][1]}"
    print(f"{nodes:>10} {r['dx']:9.5f} {'yes' if r['converged'] else 'NO':>5} {r['time']:6.3f} "
          f"{r['tip_error_percent']:10.3f} {rate('tip_error_percent'):>5} "
          f"{r['axis_l2_error_percent']:10.3f} {rate('axis_l2_error_percent'):>5} {r['wall_seconds']:9.1f}")
    prev = r
EOF
