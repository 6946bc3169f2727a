#!/usr/bin/env bash
# The default test suite under AddressSanitizer and UndefinedBehaviorSanitizer: configures
# build-asan/ with FLARE_SANITIZE=ON (gcc, Release with line tables, no benchmarks; the CLI's and the
# tests' own code at -O1), builds it and runs every test that is not labelled `stress` or
# `benchmark` and not listed in tests/sanitize-skip.txt (the heavy statistical tests, which say
# there what covers their code; --all runs them too). Extra arguments go to ctest.
# A sanitizer report fails the test that triggered it (UBSan does not recover; ASan aborts).
#
#   scripts/test-sanitize.sh [--all] [ctest arguments]
set -euo pipefail
cd "$(dirname "$0")/.."
all=0
if [ "${1:-}" = --all ]; then all=1; shift; fi
scripts/setup.sh >/dev/null
start=$(date +%s)
if [ ! -f build-asan/build.ninja ]; then
  cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS="-g1" -DFLARE_SANITIZE=ON \
    -DFLARE_BUILD_BENCHMARKS=OFF >/dev/null
fi
cmake --build build-asan --parallel "$(nproc)"
built=$(date +%s)

skip=()
if [ "$all" = 0 ]; then
  # Every listed name must still be a test: a renamed one would otherwise drop out unseen.
  tests=$(ctest --test-dir build-asan -N | sed -n 's/^ *Test *#[0-9]*: //p')
  names=$(sed -e 's/#.*//' -e 's/[[:space:]]//g' tests/sanitize-skip.txt | grep -v '^$')
  for name in $names; do
    grep -qxF "$name" <<<"$tests" || { echo "test-sanitize: tests/sanitize-skip.txt names no test: $name" >&2; exit 1; }
  done
  skip=(-E "^($(echo $names | sed -e 's/\./\\./g' -e 's/ /|/g'))\$")
  echo "test-sanitize: leaving out the $(wc -w <<<"$names") tests of tests/sanitize-skip.txt (--all runs them)"
fi

export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:${ASAN_OPTIONS:-}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:${UBSAN_OPTIONS:-}"
ctest --test-dir build-asan --output-on-failure --parallel "$(nproc)" --label-exclude "stress|benchmark" "${skip[@]}" "$@"
echo "test-sanitize: build $((built - start)) s, tests $(($(date +%s) - built)) s"
