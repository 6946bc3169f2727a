#!/usr/bin/env bash
# Set-up if needed, then build everything in build/.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ ! -f build/build.ninja ]; then scripts/setup.sh; fi
cmake --build build --parallel "$(nproc)"
