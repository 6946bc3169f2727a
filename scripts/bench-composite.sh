#!/usr/bin/env bash
# The `flare composite` benchmark (docs/BENCHMARKS.md, "flare composite"): the example night plate
# (scripts/make-plates.py, 1920 x 1080) through the double Gauss at f/4, timed at preview quality
# and to a target error, with the flare's error against a long reference, and the time against
# the number of lights.
# Usage: scripts/bench-composite.sh [OUT_DIR]     (default out/bench-composite; needs build/src/flare)
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-out/bench-composite}"
flare="${FLARE:-build/src/flare}"
mkdir -p "$out"
/usr/bin/python3 scripts/make-plates.py "$out" >/dev/null
lens=(--lens double-gauss-50mm --f-number 4)

# One run: prints wall seconds, CPU seconds (user + sys), lights and the ghosts' relative L2 error
# against the reference (flare compare on the `ghost` layer: the part of the flare that is
# estimated; the starburst is computed, not sampled).
run() {
  local name="$1"; shift
  /usr/bin/time -f "%e %U %S" -o "$out/$name.time" nice -n 10 "$flare" composite "$out/night-street.exr" "${lens[@]}" \
    -o "$out/$name.exr" "$@" > "$out/$name.log" 2>&1
  read -r wall user sys < "$out/$name.time"
  local lights error
  lights=$(grep -o "rendering the flare of [0-9]* light" "$out/$name.log" | grep -o "[0-9]*" || echo 0)
  error=$("$flare" compare "$out/$name.exr" "$out/reference.exr" --layer ghost --json |
          /usr/bin/python3 -c "import json,sys; print('%.3f' % json.load(sys.stdin)['rel_l2'])")
  printf "%-28s %6s lights %8.1f s wall %8.1f s CPU   ghost rel. L2 error %s\n" "$name" "$lights" "$wall" \
    "$(/usr/bin/python3 -c "print($user + $sys)")" "$error"
}

# The reference: cells of 16 px (no merging beyond them, no light limit) and 16 passes.
if [ ! -f "$out/reference.exr" ]; then
  /usr/bin/time -f "%e %U %S" -o "$out/reference.time" nice -n 10 "$flare" composite "$out/night-street.exr" "${lens[@]}" \
    -o "$out/reference.exr" --cell-px 16 --max-lights 65536 --passes 16 > "$out/reference.log" 2>&1
fi
echo "reference: $(grep -o 'rendering the flare of [0-9]* light(s)' "$out/reference.log"), $(cat "$out/reference.time") (wall, user, sys s)"

run preview-default
for k in 8 16 32; do run "max-lights-$k" --max-lights "$k"; done
run target-error-5pct --target-error 0.05
