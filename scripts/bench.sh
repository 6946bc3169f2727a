#!/usr/bin/env bash
# Benchmarks (docs/BENCHMARKS.md). Installs what it needs (scripts/setup.sh --bench: the build's
# packages and python3-matplotlib; run as root the first time), builds the benchmark tools
# (Release, in $FLARE_BUILD_DIR, default build/) and runs:
#
#   scripts/bench.sh [ARGS]          time against error: naive and guided photon tracing and the
#                                    preview against a cached reference, for the double Gauss, the
#                                    zoom (wide and tele) and the fisheye with two light positions
#                                    each (about 60 minutes on 2 cores). Writes out/bench/timing.csv,
#                                    summary.csv, error-vs-time.png, error-vs-time-flare.png, strip.png;
#                                    references are cached in out/bench-cache/.
#   scripts/bench.sh --quick [ARGS]  the same, one light per lens, 96 px wide, smaller references
#                                    and budgets: under 5 minutes, into out/bench/quick/
#   scripts/bench.sh --micro [ARGS]  the Google Benchmark micro-benchmarks (flare_bench); ARGS go to
#                                    Google Benchmark (e.g. --benchmark_filter=Preview
#                                    --benchmark_repetitions=3 --benchmark_report_aggregates_only=true);
#                                    a first argument --benchmark_... implies --micro
#
# Other ARGS go to tests/bench/time_error.cpp (--cases dg-15-0,fe-45-20, --naive-seconds S, --target E,
# --list, ...). Set FLARE_BENCH_OUT to write elsewhere than out/bench (or out/bench/quick).
set -euo pipefail
cd "$(dirname "$0")/.."
build="${FLARE_BUILD_DIR:-build}"

mode=timing
case "${1:-}" in
  --micro) mode=micro; shift ;;
  --quick) mode=quick; shift ;;
  --benchmark_*) mode=micro ;;  # Google Benchmark's own options imply --micro
esac

scripts/setup.sh --bench
if [ ! -f "$build/build.ninja" ]; then
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DFLARE_BUILD_BENCHMARKS=ON >/dev/null
fi
cmake --build "$build" --parallel "$(nproc)" --target flare_bench flare_time_error >/dev/null

if [ "$mode" = micro ]; then
  exec "$build/tests/bench/flare_bench" "$@"
fi

out="${FLARE_BENCH_OUT:-out/bench}"
quick=()
if [ "$mode" = quick ]; then quick=(--quick); out="${FLARE_BENCH_OUT:-out/bench/quick}"; fi
mkdir -p "$out"
start=$(date +%s)
"$build/tests/bench/flare_time_error" "${quick[@]}" --csv "$out/timing.csv" --summary "$out/summary.csv" \
  --strip "$out/strip" --cache out/bench-cache "$@"
/usr/bin/python3 scripts/plot_bench.py "$out"
echo "bench: $(( $(date +%s) - start )) s; machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), load $(cut -d' ' -f1-3 /proc/loadavg)"
