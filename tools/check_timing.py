#!/usr/bin/env python3
"""Regression timing for CI: instruction counts of a short fixed workload.

Runs build/bench/tsph-block-run under callgrind (1 thread) for each workload of
bench/baseline.json, counts the instructions of the steps alone (the function
run_steps; setup excluded), and fails (exit 1) when any count exceeds its baseline by
more than the threshold. Instruction counts do not depend on the load of a shared
machine (repeat runs agree to a few parts per million, bench/RESULTS.md), so a 10 %
threshold catches a real 30 % slowdown and is never tripped by noise. A count well
below its baseline is reported (update the baseline with --update), not failed; so is
one more than 1 % above it (a drift to look into before it adds up).

  tools/check_timing.py                 # compare with bench/baseline.json
  tools/check_timing.py --update        # rewrite the baseline from this tree
  tools/check_timing.py --binary PATH   # another build of tsph-block-run
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BASELINE = os.path.join(ROOT, "bench", "baseline.json")
DRIFT = 0.01  # a ratio above 1 + DRIFT (and within the threshold) is reported


def count_instructions(binary, args):
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "callgrind.out")
        command = ["valgrind", "--tool=callgrind", "--callgrind-out-file=" + out,
                   "--collect-atstart=no", "--toggle-collect=*run_steps*", binary] + args
        env = dict(os.environ, OMP_NUM_THREADS="1", OMP_WAIT_POLICY="PASSIVE")
        result = subprocess.run(command, env=env, capture_output=True, text=True)
        if result.returncode != 0:
            sys.exit("check_timing: error: %s failed (status %d):\n%s"
                     % (" ".join(command), result.returncode, result.stderr[-2000:]))
        with open(out) as f:
            for line in f:
                m = re.match(r"summary:\s+(\d+)", line) or re.match(r"totals:\s+(\d+)", line)
                if m:
                    if int(m.group(1)) == 0:
                        sys.exit("check_timing: error: %s counted no instruction in "
                                 "run_steps (is it a tsph-block-run with that function?)"
                                 % binary)
                    return int(m.group(1))
    sys.exit("check_timing: error: no instruction total in callgrind's output")


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--binary", default=os.path.join(ROOT, "build", "bench", "tsph-block-run"))
    parser.add_argument("--baseline", default=BASELINE)
    parser.add_argument("--update", action="store_true", help="rewrite the baseline counts")
    o = parser.parse_args()
    if not os.access(o.binary, os.X_OK):
        sys.exit("check_timing: error: binary = '%s' is not an executable: build it first "
                 "(./tools/build.sh --target tsph-block-run)" % o.binary)
    with open(o.baseline) as f:
        baseline = json.load(f)
    threshold = float(baseline["threshold"])
    if not 0.0 < threshold < 1.0:
        sys.exit("check_timing: error: threshold = %s in %s is invalid: must lie in (0, 1)"
                 % (threshold, o.baseline))
    failed = False
    for w in baseline["workloads"]:
        count = count_instructions(o.binary, w["args"])
        if o.update:
            w["instructions"] = count
            print("%-10s %14d instructions (baseline updated)" % (w["name"], count))
            continue
        ratio = count / w["instructions"]
        verdict = "ok"
        if ratio > 1.0 + threshold:
            verdict, failed = "REGRESSION", True
        elif ratio < 1.0 - threshold:
            verdict = "faster: update the baseline (--update)"
        elif ratio > 1.0 + DRIFT:
            # Below the threshold but not noise (counts repeat to parts per million): a
            # compiler's inlining change once cost 1.8 % unseen (bench/RESULTS.md).
            verdict = "ok, but +%.1f %% drift: find its cause before it adds up" % (100 * (ratio - 1.0))
        print("%-10s %14d instructions, baseline %14d, ratio %.4f  %s"
              % (w["name"], count, w["instructions"], ratio, verdict))
    if o.update:
        with open(o.baseline, "w") as f:
            json.dump(baseline, f, indent=2)
            f.write("\n")
        return 0
    if failed:
        print("check_timing: throughput regression beyond %.0f %% (instruction counts)"
              % (100 * threshold))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
