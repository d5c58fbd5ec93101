#!/usr/bin/env bash
# The whole test suite: builds everything if needed, then runs ctest.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/tools/build.sh"
cd "${TSPH_BUILD_DIR:-$root/build}"
ctest --output-on-failure -j "$(nproc)" "$@"
