#!/usr/bin/env bash
# Set-up if needed, build, and run the default test suite (everything not labelled `stress`
# or `benchmark`). Extra arguments go to ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh
ctest --test-dir build --output-on-failure --parallel "$(nproc)" --label-exclude "stress|benchmark" "$@"
