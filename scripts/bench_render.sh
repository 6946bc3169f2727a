#!/usr/bin/env bash
# Time against error of the final render: guided vs naive photon tracing on the ghost layer of the
# double Gauss (single-layer MgF2 coatings) with the sun 15° off axis. Writes the measured points
# to out/render-error.csv and prints the time each method needs to reach 5 % relative L2 error
# and their ratio (see tests/bench/render_error.cpp). About 5 minutes on 2 cores; --quick: ~1.
# Extra arguments go to the program (e.g. --field 10,5 --resolution 384,256).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh >/dev/null
mkdir -p out
build/tests/bench/flare_render_error --csv out/render-error.csv "$@"
