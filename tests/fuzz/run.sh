#!/usr/bin/env bash
# A short libFuzzer run of every target (docs/reliability.md, Fuzzing): builds the preset `fuzz`
# (clang-14, ASan + UBSan), copies each seed corpus to a scratch folder and fuzzes it.
#   tests/fuzz/run.sh [SECONDS_PER_TARGET (default 30)] [TARGET...]
# Exit status 0 if no target found anything; a finding leaves its input in the scratch
# folder (printed) and stops with libFuzzer's status.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$root"
seconds="${1:-30}"
shift || true
targets=("$@")
[ "${#targets[@]}" -gt 0 ] || targets=(fuzz_particle_file fuzz_case_file fuzz_checkpoint)
cmake --preset fuzz >/dev/null
cmake --build --preset fuzz -j "$(nproc)" --target "${targets[@]}" >/dev/null
scratch="$(mktemp -d /tmp/tsph-fuzz.XXXXXX)"
for target in "${targets[@]}"; do
  corpus="$scratch/${target#fuzz_}"
  mkdir -p "$corpus"
  cp "tests/fuzz/corpus/${target#fuzz_}/"* "$corpus/"
  echo "== $target, $seconds s (corpus and any finding in $corpus)" >&2
  # -timeout: an input that takes 10 s is a finding (a hang); -rss_limit_mb: 2 GiB.
  set +e
  "build-fuzz/tests/fuzz/$target" -max_total_time="$seconds" -max_len=4096 -timeout=10 \
    -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$corpus/" "$corpus" >"$corpus.log" 2>&1
  status=$?
  set -e
  grep -E "^#[0-9]+.*DONE|stat::number_of_executed_units|stat::peak_rss_mb|ERROR|SUMMARY|Test unit written|^==" \
    "$corpus.log" >&2 || true
  if [ "$status" -ne 0 ]; then
    tail -n 40 "$corpus.log" >&2
    echo "$target: finding (status $status); input and log in $scratch" >&2
    exit "$status"
  fi
done
rm -rf "$scratch"
