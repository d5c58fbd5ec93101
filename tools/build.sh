#!/usr/bin/env bash
# Configures (once) and builds tsph in build/ (Release, tests and benchmarks on).
# Extra arguments are passed to `cmake --build` (for example: --target tsph).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/tools/setup.sh"
build="${TSPH_BUILD_DIR:-$root/build}"
if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release -DBUILD_TESTING=ON \
    -DTSPH_BUILD_BENCHMARKS=ON >/dev/null
fi
cmake --build "$build" -j "$(nproc)" "$@" | grep -Ev '^\[ *[0-9]+%\]|^Consolidate|^gmake' || true
exit "${PIPESTATUS[0]}"
