#!/usr/bin/env bash
# The `flare composite` benchmark (docs/BENCHMARKS.md, "flare composite"): the example night plate
# (scripts/make-plates.py, 1920 x 1080) through the double Gauss at f/4, timed at preview quality
# and to a target error, with the flare's error against a long reference, and the time against
# the number of sources.
# Usage: scripts/bench-composite.sh [OUT_DIR]     (default out/bench-composite; needs build/src/flare)
#   FLARE=path      the binary to time (default build/src/flare)
#   REFERENCE_FLARE=path  the binary that makes the reference, once (default $FLARE)
#   BEFORE=path     also time this binary (the build before a change), each case right after $FLARE's
#   NO_REFERENCE=1  neither make nor use the reference (no error column; compare later)
#   QUICK=1         only the preview cases and the threshold series (no region-size, cell or target runs)
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-out/bench-composite}"
flare="${FLARE:-build/src/flare}"
reference_flare="${REFERENCE_FLARE:-$flare}"
before="${BEFORE:-}"
mkdir -p "$out"
[ -f "$out/night-street.exr" ] || /usr/bin/python3 scripts/make-plates.py "$out" >/dev/null
lens=(--lens double-gauss-50mm --f-number 4)

# One run: prints lights, wall seconds, CPU seconds (user + sys), the estimated ghost error and the
# ghosts' relative L2 error against the reference (flare compare on the `ghost` layer: the part of
# the flare that is estimated; the starburst is computed, not sampled).
run() {
  run_with "$flare" "$@"
  if [ -n "$before" ]; then local name="$1"; shift; run_with "$before" "before-$name" "$@"; fi
}
run_with() {
  local flare="$1"; shift
  local name="$1"; shift
  /usr/bin/time -f "%e %U %S" -o "$out/$name.time" nice -n 10 "$flare" composite "$out/night-street.exr" "${lens[@]}" \
    -o "$out/$name.exr" "$@" > "$out/$name.log" 2>&1
  read -r wall user sys < "$out/$name.time"
  local lights estimated error
  lights=$(grep -o "rendering the flare of [0-9]* light" "$out/$name.log" | grep -o "[0-9]*" || echo 0)
  estimated=$(grep -o "estimated ghost error [0-9.e+-]*%" "$out/$name.log" | tail -1 | grep -o "[0-9.e+-]*%" || echo -)
  [ -f "$out/reference.exr" ] || { printf "%-26s %4s lights %7.1f s wall %7.1f s CPU  estimated %6s\n" "$name" "$lights" "$wall" "$(/usr/bin/python3 -c "print($user + $sys)")" "$estimated"; return; }
  error=$("$flare" compare "$out/$name.exr" "$out/reference.exr" --layer ghost --json |
          /usr/bin/python3 -c "import json,sys; print('%.3f' % json.load(sys.stdin)['rel_l2'])")
  printf "%-26s %4s lights %7.1f s wall %7.1f s CPU  estimated %6s  ghost rel. L2 error %s\n" "$name" "$lights" "$wall" \
    "$(/usr/bin/python3 -c "print($user + $sys)")" "$estimated" "$error"
}

# The reference, made once: region lights of 1.5 degrees (their analyses even closer to every
# pixel's own) at 64 passes of 256 beams (an estimated 2 %: well below the 5 % it judges); the
# ghosts only (the starburst is computed).
if [ "${NO_REFERENCE:-0}" != 1 ] && [ ! -f "$out/reference.exr" ]; then
  /usr/bin/time -f "%e %U %S" -o "$out/reference.time" nice -n 10 "$reference_flare" composite "$out/night-street.exr" \
    "${lens[@]}" -o "$out/reference.exr" --region-deg 1.5 --passes 64 --beams-per-pass 256 --no-diffraction \
    > "$out/reference.log" 2>&1
fi
[ "${NO_REFERENCE:-0}" = 1 ] || echo "reference: $(grep -o 'rendering the flare of [0-9]* light(s)' "$out/reference.log"), $(cat "$out/reference.time") (wall, user, sys s)"
echo "load: $(uptime)"

run preview-default
run preview-no-diffraction --no-diffraction
# The floor: one pass of 8 beams a light, no diffraction; and the same written uncompressed (this
# build's option only: BEFORE's build may not have it).
run preview-floor --no-diffraction --passes 1 --beams-per-pass 8
run_with "$flare" preview-floor-uncompressed --no-diffraction --passes 1 --beams-per-pass 8 --compression none
# Time against the number of sources: fewer source pixels above a higher threshold (1e9: none).
for t in 1e9 1000 100; do run "threshold-$t" --threshold "$t"; done
[ "${QUICK:-0}" = 1 ] && exit 0
for deg in 1.5 5; do run "region-deg-$deg" --region-deg "$deg"; done
run cells-64px --cell-px 64   # as before region lights (the old default: 64 beams a pass, cells grown to 64 lights)
run target-error-5pct --target-error 0.05
