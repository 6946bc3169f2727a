#!/usr/bin/env bash
# Set-up if needed, build, and run the main job on the embedded default lens: the paraxial
# report and a cutaway drawing with traced ray fans. Prints where the output went.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh >/dev/null
mkdir -p out
build/src/flare lens info double-gauss-50mm
build/src/flare lens info double-gauss-50mm --json > out/double-gauss-50mm.json
build/src/flare lens draw double-gauss-50mm -o out/double-gauss-50mm.svg --rays 11
echo
echo "output: $(pwd)/out/double-gauss-50mm.json (paraxial data), $(pwd)/out/double-gauss-50mm.svg (cutaway)"
