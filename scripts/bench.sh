#!/usr/bin/env bash
# Set-up if needed, build, and run the micro-benchmarks. Extra arguments go to Google Benchmark
# (e.g. --benchmark_repetitions=5 --benchmark_report_aggregates_only=true).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh >/dev/null
build/tests/bench/flare_bench "$@"
