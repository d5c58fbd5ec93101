#!/usr/bin/env bash
# The main job: builds tsph if needed and reproduces the seed's 1D bar (Table 1),
# printing our L2 errors beside the paper's. Extra arguments go to tsph-bar
# (see `build/tools/tsph-bar --help`), for example: tools/run.sh --kernel wendland_c2
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/tools/build.sh" --target tsph-bar
exec "${TSPH_BUILD_DIR:-$root/build}/tools/tsph-bar" --table1 --out "$root/out/bar-table1" "$@"
