#!/usr/bin/env bash
# Builds the libFuzzer targets (clang 16, -fsanitize=fuzzer,address,undefined; tests/fuzz/) in
# build-fuzz/ and runs one of them for SECONDS seconds. Installs clang 16 first if needed (as root).
#
#   scripts/fuzz.sh lens|zmx|agf|scene|exr|checkpoint|vdb SECONDS [more libFuzzer arguments, e.g. -jobs=2]
#
# The corpus grows in build-fuzz/corpus/TARGET, seeded from the source tree (lenses/*.lens and
# tests/data/*.dat for lens; docs/examples/*.json and tests/data/scenes/*.json for scene; small
# generated EXRs, a checkpoint and a bare film for exr and checkpoint; small generated .vdb files
# for vdb, as the shipped volumes/*.vdb are 40-600 kB; generated .zmx files for zmx, as none is
# shipped; excerpts of the shipped lenses/glass/*.agf, 400-640 kB each, for agf; and the kept
# regression inputs tests/data/fuzz/TARGET/*). A crash leaves its input in build-fuzz/artifacts/TARGET/ and
# the script exits non-zero: copy the input to tests/data/fuzz/TARGET/ (with a descriptive name)
# and it replays in the default suite (FuzzRegressions.EveryKeptInputReplaysCleanly).
set -euo pipefail
cd "$(dirname "$0")/.."

usage() { echo "usage: scripts/fuzz.sh lens|zmx|agf|scene|exr|checkpoint|vdb SECONDS [libFuzzer arguments]" >&2; exit 2; }
[ $# -ge 2 ] || usage
target=$1 seconds=$2
shift 2
case "$target" in lens|zmx|agf|scene|exr|checkpoint|vdb) ;; *) usage ;; esac
[[ "$seconds" =~ ^[0-9]+$ ]] || usage

# Installs clang 16 and libFuzzer (and the engine's packages) when missing; a no-op otherwise.
scripts/setup.sh --fuzz

if [ ! -f build-fuzz/build.ninja ]; then
  CC=clang-16 CXX=clang++-16 cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DFLARE_FUZZ=ON \
    -DFLARE_BUILD_TESTS=OFF -DFLARE_BUILD_BENCHMARKS=OFF >/dev/null
fi
cmake --build build-fuzz --parallel "$(nproc)" --target "fuzz_$target" flare_fuzz_seeds

seeds=build-fuzz/seeds/$target corpus=build-fuzz/corpus/$target artifacts=build-fuzz/artifacts/$target
rm -rf "$seeds"
mkdir -p "$seeds" "$corpus" "$artifacts"
case "$target" in
  lens) cp lenses/*.lens tests/data/*.dat "$seeds"/ ;;
  scene) cp docs/examples/*.json tests/data/scenes/*.json "$seeds"/ ;;
  zmx | agf | exr | checkpoint | vdb)
    build-fuzz/tests/fuzz/flare_fuzz_seeds build-fuzz/seeds/generated >/dev/null
    cp build-fuzz/seeds/generated/"$target"/* "$seeds"/ ;;
esac
for f in tests/data/fuzz/"$target"/*; do
  [ -f "$f" ] && [ "$(basename "$f")" != README.md ] && cp "$f" "$seeds"/
done
dict=()
[ -f "tests/fuzz/$target.dict" ] && dict=(-dict="tests/fuzz/$target.dict")

# No allocation limit below libFuzzer's -malloc_limit_mb: under ASan a failed `new` aborts instead
# of throwing std::bad_alloc, so a tighter limit would report the readers' (legitimate) handling of
# huge declared sizes as crashes.
export ASAN_OPTIONS="allocator_may_return_null=1:${ASAN_OPTIONS:-}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:${UBSAN_OPTIONS:-}"
set +e
"build-fuzz/tests/fuzz/fuzz_$target" "$corpus" "$seeds" "${dict[@]}" -max_total_time="$seconds" \
  -artifact_prefix="$artifacts/" -print_final_stats=1 -timeout=30 -rss_limit_mb=4096 -malloc_limit_mb=4096 "$@" \
  2>&1 | tee "build-fuzz/fuzz-$target.log" | grep -v -e '^#[0-9]' -e '^"' -e '^###'  # progress: in the log
status=${PIPESTATUS[0]}
set -e
runs=$(grep -o "stat::number_of_executed_units: *[0-9]*" "build-fuzz/fuzz-$target.log" | grep -o "[0-9]*$" | tail -1)
echo "fuzz_$target: ${runs:-?} executions in ${seconds} s, exit status $status (log: build-fuzz/fuzz-$target.log)"
exit "$status"
