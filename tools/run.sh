#!/usr/bin/env bash
# The main job: builds tsph if needed and reproduces the seed's 1D bar (Table 1) from
# tools/cases/bar.toml, printing our L2 errors beside the paper's. Extra arguments go to
# `tsph table1` (see `build/tools/tsph table1 --help`), for example:
#   tools/run.sh --set method.kernel=wendland_c2
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/tools/build.sh" --target tsph
exec "${TSPH_BUILD_DIR:-$root/build}/tools/tsph" table1 "$root/tools/cases/bar.toml" --out "$root/out/bar-table1" "$@"
