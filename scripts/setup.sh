#!/usr/bin/env bash
# Installs every Debian package the build needs (idempotent; run as root) and configures a
# Release build in build/. Usage: scripts/setup.sh [extra cmake arguments]
#        scripts/setup.sh --fuzz   also installs clang and libFuzzer, and configures nothing
#                                  (scripts/fuzz.sh configures build-fuzz/ itself)
#        scripts/setup.sh --bench  also installs python3-matplotlib (the plots of scripts/bench.sh),
#                                  and configures nothing (scripts/bench.sh builds what it runs)
#        scripts/setup.sh --tests [cmake arguments]  also installs what only the test suite needs
#                                  (Blender, for the add-on's headless test; scripts/test.sh)
set -euo pipefail
cd "$(dirname "$0")/.."

fuzz=0
bench=0
if [ "${1:-}" = "--fuzz" ]; then fuzz=1; shift; fi
if [ "${1:-}" = "--bench" ]; then bench=1; shift; fi
tests=0
if [ "${1:-}" = "--tests" ]; then tests=1; shift; fi

packages=(
  build-essential cmake ninja-build pkg-config python3
  libglm-dev libopenexr-dev libopenvdb-dev libtbb-dev libboost-iostreams-dev libblosc-dev
  nlohmann-json3-dev libcli11-dev libgtest-dev libgmock-dev libbenchmark-dev libpng-dev
  # the starburst's FFT (src/flare/wave)
  libkissfft-dev
  # SIMD packet tracing with run-time dispatch (src/flare/optics/PacketTracer)
  libhwy-dev
  # the Python module (src/python, docs/python.md), for Debian's /usr/bin/python3
  pybind11-dev python3-dev python3-numpy
  # multi-process renders and data sets (src/flare/distributed, docs/distributed.md); optional
  # component: the build works without it
  libopenmpi-dev openmpi-bin
  # plate colour spaces and display transforms of `flare composite` (src/cli/Composite*)
  libopencolorio-dev
)
# Only for a fuzz build: clang with its sanitizer and libFuzzer runtimes (16: the engine captures
# structured bindings in lambdas, which clang supports from 16 on; Debian 12's default is 14).
if [ "$fuzz" = 1 ]; then packages+=(clang-16 libclang-rt-16-dev); fi
# Only for the benchmark plots (Debian's python3, /usr/bin/python3).
if [ "$bench" = 1 ]; then packages+=(python3-matplotlib); fi
# Only for the test suite: Blender runs the add-on's headless test (src/blender, docs/blender.md;
# 90 MB of packages, 311 MB installed, about 40 s; skipped with a message where it is absent).
if [ "$tests" = 1 ]; then packages+=(blender); fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  if [ "$(id -u)" -ne 0 ]; then
    echo "setup: missing packages (${missing[*]}); run as root to install them" >&2
    exit 1
  fi
  echo "setup: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

if [ "$fuzz" = 1 ] || [ "$bench" = 1 ]; then exit 0; fi
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
echo "setup: configured build/ (Release)"
