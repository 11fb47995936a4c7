#!/usr/bin/env bash
# The engine's Arm SIMD paths (NEON, SVE, SVE2 and the portable one) checked against each other
# on an x86-64 machine: the core library and cpp/tools/simd_paths_check.cpp cross-compiled for
# aarch64 and run under QEMU's user-mode emulation with a CPU that has SVE2 (-cpu max), at
# three SVE vector lengths. The same program built natively checks this machine's paths
# (AVX-512, AVX2, portable).
#
# usage: benchmarks/arm_paths.sh [--setup]
#   --setup  first install what it needs from Debian (run as root): the aarch64 cross compiler
#            (with OpenMP's runtime), QEMU, and the arm64 builds of Highway and FFTW
# environment:
#   BUILD  build folders' parent (default out/arm-paths)
#
# Each run prints one line per scene, thread count and path, and "every path gives the same
# state" when they agree to the bit; the exit status is 1 when an emulated check fails (its
# paths disagree, or it stops with an error). The native check takes about a second, each emulated one about a
# minute; nothing here is a timing.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
build=${BUILD:-$root/out/arm-paths}

if [ "${1:-}" = "--setup" ]; then
  dpkg --add-architecture arm64
  apt-get update
  apt-get install -y cmake pkg-config g++ g++-aarch64-linux-gnu qemu-user libeigen3-dev \
    libhwy-dev libfftw3-dev libhwy-dev:arm64 libfftw3-dev:arm64
elif [ -n "${1:-}" ]; then
  echo "usage: $0 [--setup]" >&2
  exit 2
fi

configure() {  # folder, extra cmake arguments...
  local dir=$1
  shift
  cmake -S "$root" -B "$dir" -DCMAKE_BUILD_TYPE=Release -DMILLSCOPE_PYTHON_MODULE=OFF \
    -DMILLSCOPE_TOOLS=ON "$@" > "$dir.log"
  cmake --build "$dir" --target simd_paths_check -j "$(nproc)" >> "$dir.log"
}

mkdir -p "$build"
echo "== x86-64, this machine's paths"
configure "$build/native"
"$build/native/simd_paths_check" | tee "$build/native.txt"

# pkg-config finds the arm64 builds of Highway and FFTW; the compilers and the sysroot are
# Debian's cross toolchain.
PKG_CONFIG_LIBDIR=/usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig \
  configure "$build/aarch64" \
  -DCMAKE_SYSTEM_NAME=Linux -DCMAKE_SYSTEM_PROCESSOR=aarch64 \
  -DCMAKE_CXX_COMPILER=aarch64-linux-gnu-g++ \
  -DCMAKE_FIND_ROOT_PATH=/usr/aarch64-linux-gnu \
  -DCMAKE_FIND_ROOT_PATH_MODE_PROGRAM=NEVER

# SVE's code does not know the vector length when compiled: run it at QEMU's default (512
# bits), at the shortest (128) and at the longest (2048). The arm64 C library and the libraries
# above come from Debian's arm64 packages (multiarch), where QEMU finds them by itself.
status=0
for bytes in 64 16 256; do
  echo "== aarch64 under QEMU (-cpu max: NEON, SVE and SVE2 of $((8 * bytes)) bits)"
  QEMU_CPU="max,sve-default-vector-length=$bytes" qemu-aarch64 "$build/aarch64/simd_paths_check" |
    tee "$build/aarch64-sve$((8 * bytes)).txt" || status=1
done

# Not promised, but worth knowing: whether the two architectures end in the same states too
# (they share the engine's arithmetic; the C library's sin and cos, used for the lifters'
# angles, may round differently).
fingerprints() { awk '/threads=/ {print $2, $3, $4, $5, $6, $NF}' "$1" | sort -u; }
if [ "$(fingerprints "$build/native.txt")" = "$(fingerprints "$build/aarch64-sve512.txt")" ]; then
  echo "aarch64 and x86-64 end in the same states"
else
  echo "aarch64 and x86-64 end in different states"
fi
exit "$status"
