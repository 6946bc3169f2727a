#!/usr/bin/env bash
# Issue 27's benchmark (docs/BENCHMARKS.md, "Every light's ghosts as beams, and the preview as the
# render's first passes"): time against error for point and disk lights and for the preview.
#
#   scripts/bench-lights.sh [REFERENCE_SECONDS]
#
# 1. docs/examples/street-lights.json and docs/examples/lamp-and-sun-telephoto.json rendered with
#    --time 15 and 30 (wall time, analysis included): the report's estimated errors, and the ghost
#    layer and the flare without the direct image against a long reference (REFERENCE_SECONDS,
#    default 400, --target-error 0, another seed; cached in out/bench-cache/).
# 2. The default scene's preview at 1, 2, 4 and 8 passes: wall time (without layers) and its ghost
#    layer against a converged render's (cached likewise).
# Writes out/bench/lights/ and prints one line per run. About 40 minutes with the references, 5
# without (they are cached).
set -euo pipefail
cd "$(dirname "$0")/.."
reference_s="${1:-400}"
scripts/setup.sh >/dev/null
scripts/build.sh >/dev/null
flare=build/src/flare
out=out/bench/lights
cache=out/bench-cache
mkdir -p "$out" "$cache"
error() { /usr/bin/python3 scripts/layer-error.py "$@" | tr '\n' ' '; }
report() {
  /usr/bin/python3 -c "
import json, sys
r = json.load(open(sys.argv[1]))
layers = ' '.join(f'{k} {v[\"estimated_relative_error\"]:.4f}' for k, v in r['layers'].items())
print(f'passes {r[\"passes\"]} estimated: {layers} flare {r[\"flare_estimated_relative_error\"]:.4f}', end=' ')" "$1"
}
seconds() { /usr/bin/python3 -c "import time; print(f'{time.time():.2f}')"; }

for scene in street-lights lamp-and-sun-telephoto; do
  ref="$cache/$scene-ref-${reference_s}s.exr"
  if [ ! -f "$ref" ]; then
    "$flare" render "docs/examples/$scene.json" --time "$reference_s" --target-error 0 --seed 99 -o "$ref" --quiet >/dev/null
  fi
  for t in 15 30; do
    start=$(seconds)
    "$flare" render "docs/examples/$scene.json" --time "$t" -o "$out/$scene-$t.exr" --report "$out/$scene-$t.json" --quiet >/dev/null
    wall=$(/usr/bin/python3 -c "print(f'{$(seconds) - $start:.1f}')")
    echo "$scene --time $t: wall $wall s; $(report "$out/$scene-$t.json"); ghost against the reference: $(error "$out/$scene-$t.exr" "$ref" --layer ghost)"
  done
done

ref="$cache/default-ref-300s.exr"
if [ ! -f "$ref" ]; then "$flare" render --time 300 --target-error 0 --seed 11 -o "$ref" --quiet >/dev/null; fi
for passes in 1 2 4 8; do
  start=$(seconds)
  "$flare" preview -o "$out/preview-time.exr" --passes "$passes" --quiet >/dev/null
  wall=$(/usr/bin/python3 -c "print(f'{$(seconds) - $start:.2f}')")
  "$flare" preview -o "$out/preview-$passes.exr" --passes "$passes" --layers --float-layers --quiet >/dev/null
  echo "default preview, $passes passes: wall $wall s; ghost against the converged render: $(error "$out/preview-$passes.exr" "$ref" --layer ghost)"
done
echo "bench-lights: machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), load $(cut -d' ' -f1-3 /proc/loadavg)"
