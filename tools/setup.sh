#!/usr/bin/env bash
# Installs the Debian packages tsph needs, only those missing; silent when none is.
# Used by tools/run.sh and tools/test.sh; safe to run again.
set -euo pipefail

packages=(
  g++ cmake make            # toolchain (C++20, CMake >= 3.22)
  libeigen3-dev             # small dense matrices (correction matrices, tensors)
  libnanoflann-dev          # kd-tree neighbour search
  libgtest-dev              # GoogleTest: the test suite
  libbenchmark-dev          # Google Benchmark: bench/
  libfmt-dev                # formatted output
  libcli11-dev              # command-line parsing
  libtomlplusplus-dev       # case files (TOML) for the tsph command
  zlib1g-dev                # crc32: the checksum that guards checkpoints against damage
  python3-numpy python3-matplotlib  # tools/plot_*.py: figures against the exact solutions
  clang-14 libclang-rt-14-dev  # sanitizer builds: ASan/UBSan, TSan, libFuzzer (presets asan, tsan, fuzz)
  libomp-14-dev             # LLVM's OpenMP runtime and its Archer tool, which TSan understands
  valgrind                  # callgrind instruction counts: tools/check_timing.py (CI regression timing)
  ccache                    # compiler cache: a clean clone rebuilds unchanged sources from it (CMakeLists.txt, TSPH_CCACHE)
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
[ ${#missing[@]} -eq 0 ] && exit 0

echo "tsph setup: installing ${missing[*]}" >&2
sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then sudo_cmd=(sudo); else
    echo "tsph setup: need root to run: apt-get install ${missing[*]}" >&2
    exit 1
  fi
fi
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq >/dev/null
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
