#!/usr/bin/env bash
# The default test suite under AddressSanitizer and UndefinedBehaviorSanitizer: configures
# build-asan/ with FLARE_SANITIZE=ON (gcc, Release with line tables, no benchmarks), builds it and
# runs every test that is not labelled `stress` or `benchmark`. Extra arguments go to ctest.
# A sanitizer report fails the test that triggered it (UBSan does not recover; ASan aborts).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh >/dev/null
start=$(date +%s)
if [ ! -f build-asan/build.ninja ]; then
  cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS="-g1" -DFLARE_SANITIZE=ON \
    -DFLARE_BUILD_BENCHMARKS=OFF >/dev/null
fi
cmake --build build-asan --parallel "$(nproc)"
built=$(date +%s)
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:${ASAN_OPTIONS:-}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:${UBSAN_OPTIONS:-}"
ctest --test-dir build-asan --output-on-failure --parallel "$(nproc)" --label-exclude "stress|benchmark" "$@"
echo "test-sanitize: build $((built - start)) s, tests $(($(date +%s) - built)) s"
