#!/usr/bin/env bash
# The thesis's chapter-5 results made by this engine, in one command (docs/thesis.md): the flare
# of its kind of lens, an 80-200 mm f/2.8 zoom (the library's Nikon AI-S Zoom-Nikkor 80-200mm f/2.8
# ED, JP S58-54312 A Example 2), against the light's position, bounce limits, photon counts, zoom
# and focus, coatings; the lens cutaway and its strongest ghosts' ray paths; a flare merged over a
# frame. Each result is recorded with its command line, wall time, photon count and estimated error
# in OUT/manifest.json and OUT/gallery.md.
#
#   scripts/thesis.sh [--quick] [--out DIR] [--flare PROGRAM] [--python-path DIR]
#
# --quick: 192 x 128 images and seconds per image (a few minutes on two idle cores). Without it:
# 384 x 256 images and the budgets docs/thesis.md quotes (about half an hour on two idle cores); run it
# under `nice -n 10`. Both end with a check that every output was written and holds finite numbers
# (the quick run is the ctest `thesis.quick`, label `benchmark`).
# Defaults: OUT = out/thesis (out/thesis-quick), PROGRAM = build/src/flare, the Python module from
# build/python. Exit code 2 on bad arguments, 1 if a step or a check fails.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
quick=0
out=""
flare="$root/build/src/flare"
pypath="$root/build/python"
while [ $# -gt 0 ]; do
    case "$1" in
        --quick) quick=1 ;;
        --out) out=${2:?--out needs a folder}; shift ;;
        --flare) flare=${2:?--flare needs a program}; shift ;;
        --python-path) pypath=${2:?--python-path needs a folder}; shift ;;
        -h|--help) sed -n '2,16p' "$0"; exit 0 ;;
        *) echo "thesis.sh: error: unknown argument '$1' (see --help)" >&2; exit 2 ;;
    esac
    shift
done
[ -x "$flare" ] || { echo "thesis.sh: error: $flare is not a program (build first, or --flare)" >&2; exit 2; }
[ -n "$out" ] || out="$root/out/thesis$([ $quick = 1 ] && echo -quick || true)"
flare=$(cd "$(dirname "$flare")" && pwd)/$(basename "$flare")
export PYTHONPATH="$pypath${PYTHONPATH:+:$PYTHONPATH}"
py=/usr/bin/python3
[ -x "$py" ] || py=python3
tools() { "$py" "$root/scripts/thesis_tools.py" "$@"; }
"$py" -c "import flare, numpy" 2>/dev/null || {
    echo "thesis.sh: error: the flare Python module is not importable from $pypath (build it, or --python-path)" >&2; exit 2; }

mkdir -p "$out"
cd "$out"
rm -f manifest.json
lens=nikon-ai-s-zoom-nikkor-80-200mm-f2.8-ed

# Budgets. Quick: seconds per image. Full: the error or time the thesis's comparisons need.
if [ $quick = 1 ]; then
    res=192,128; study="--time 3"; sweep="--time 2"; bounce="--time 5"; composite="--passes 2"
    high="--photons 2000000 --target-error 0"; target="--target-error 0.05 --time 60"; naive="--time 8"
else
    res=384,256; study="--target-error 0.02 --time 45"; sweep="--target-error 0.03 --time 20"; bounce="--time 60"
    composite="--target-error 0.05"
    high="--photons 20000000 --target-error 0 --time 300"; target="--target-error 0.01 --time 300"; naive="--time 300"
fi

# run ID FIGURE CAPTION REPORT|- OUTPUT... -- COMMAND...: runs COMMAND (its stderr in ID.log),
# times it and records it in the manifest with its outputs and report. An OUTPUT written as
# stdout:FILE is the command's standard output (else that goes to ID.out).
run() {
    local id=$1 figure=$2 caption=$3 report=$4
    shift 4
    local outputs=() stdout="$id.out"
    while [ "$1" != "--" ]; do
        case "$1" in stdout:*) stdout=${1#stdout:}; outputs+=(--output "$stdout") ;; *) outputs+=(--output "$1") ;; esac
        shift
    done
    shift
    local start end
    start=$(date +%s.%N)
    if ! "$@" >"$stdout" 2>"$id.log"; then
        echo "thesis.sh: step $id failed: $*" >&2
        tail -5 "$id.log" >&2
        exit 1
    fi
    end=$(date +%s.%N)
    local shown="$*"
    shown=${shown//$flare/flare}
    shown=${shown/#tools /scripts/thesis_tools.py }
    [ "$stdout" = "$id.out" ] || shown="$shown > $stdout"
    local rep=()
    [ "$report" = - ] || rep=(--report "$report")
    tools record manifest.json --id "$id" --figure "$figure" --caption "$caption" \
        --command "$shown" --wall "$(awk "BEGIN { print $end - $start }")" "${rep[@]}" "${outputs[@]}"
    echo "thesis: $id ($(awk "BEGIN { printf \"%.1f\", $end - $start }") s)"
}

# The exposure the first PNG of a series chose (printed by flare render), so that the rest of the
# series is exposed alike.
exposure_of() { sed -n 's/.*PNG exposure \([-+0-9.]*\) stops.*/\1/p' "$1.log" | head -1; }

render() {  # render ID FIGURE CAPTION SCENE [flare render options...]
    local id=$1 figure=$2 caption=$3 scene=$4
    shift 4
    run "$id" "$figure" "$caption" "$id.json" "$id.png" "$id.exr" -- \
        "$flare" render "$scene" -o "$id.exr" --png "$id.png" --report "$id.json" "$@"
}

# ---- 1. The light's position (thesis 5.3.1) --------------------------------------------------
# At 80 mm the frame spans ±12.7° × ±8.5°: the centre, mid-field, the corner, and just outside.
for spec in centre:0,0 midfield:6,4 corner:12,8 outside:15,10; do
    name=${spec%%:*}
    tools scene "scene-position-$name.json" --zoom wide --field "${spec#*:}" --f-number 4 --resolution "$res" \
        --description "thesis 5.3.1: the light at the $name, 80 mm, f/4"
done
render position-midfield "5.3.1 (figs. 5.2-5.12)" "light at mid-field (6°, 4°), 80 mm f/4" scene-position-midfield.json $study
e=$(exposure_of position-midfield)
for name in centre corner outside; do
    render "position-$name" "5.3.1 (figs. 5.2-5.12)" "light at the $name, 80 mm f/4" "scene-position-$name.json" \
        $study --exposure "$e"
done

# ---- 2. Bounce limits 2, 5, 10, unbounded (thesis 5.3.2) -------------------------------------
# Uncoated (as the thesis's lenses), black interior (albedo 0: every layer is specular), unguided
# photons alone (the thesis's method: guided ghosts and chains would not obey the limit, and the
# `higher` layer, which the limit cuts, is the unguided photons' anyway).
tools scene scene-bounces.json --zoom mid --field 3,2 --f-number 4 --coating none --resolution "$res" \
    --description "thesis 5.3.2: bounce limits, uncoated, 140 mm, f/4"
reports=()
for k in 2 5 10 -1; do
    id=bounces-$([ "$k" = -1 ] && echo unbounded || echo "$k")
    extra=()
    [ "$k" = 2 ] || extra=(--exposure "$(exposure_of bounces-2)")
    render "$id" "5.3.2" "bounce limit $([ "$k" = -1 ] && echo unbounded || echo "$k"), uncoated, 140 mm f/4" \
        scene-bounces.json $bounce --mode naive --max-bounces "$k" --interior-albedo 0 "${extra[@]}"
    reports+=("$([ "$k" = -1 ] && echo unbounded || echo "$k")=$id.json")
done
tools bounces manifest.json bounces.md "${reports[@]}"

# ---- 3. Massive photon counts against a target error (thesis 5.3.3) ---------------------------
tools scene scene-brute.json --zoom wide --field 6,4 --f-number 4 --coating none --resolution "$res" \
    --description "thesis 5.3.3: brute force against guided sampling, uncoated, 80 mm, f/4"
render brute-high "5.3.3" "high photon count (guided), uncoated 80 mm f/4" scene-brute.json $high
e=$(exposure_of brute-high)
render brute-target "5.3.3" "the same scene to the target error (guided)" scene-brute.json $target --exposure "$e"
render brute-naive "5.3.3" "the thesis's method: unguided photons only, same scene" scene-brute.json \
    $naive --mode naive --exposure "$e"

# ---- 4. The lens cutaway and its strongest ghosts' ray paths (thesis 3.6, 5.14) -----------------
run cutaway "3.6" "lens cutaway at 200 mm with ray fans" - cutaway.svg -- \
    "$flare" lens draw "$lens" --zoom tele -o cutaway.svg
run ghosts-tele "5.14" "ghost table at 200 mm, light at (2°, 1.5°)" - stdout:ghosts-tele.json -- \
    "$flare" ghosts "$lens" --zoom tele --field-deg 2,1.5 --json
# The three strongest ghosts that do not reflect off the sensor (their paths stay inside the lens).
strongest=$("$py" -c "
import json, sys
t = json.load(open('ghosts-tele.json'))
sensor = t['sensor_surface_number']
g = [x['surfaces'] for x in t['ghosts'] if sensor not in x['surfaces'] and not x['pruned']][:3]
print(' '.join(f'{a},{b}' for a, b in g))")
n=0
for pair in $strongest; do
    n=$((n + 1))
    run "ghost-path-$n" "5.14" "ray paths of ghost $pair (strongest lens-only ghost #$n) at 200 mm" - "ghost-path-$n.svg" -- \
        "$flare" lens draw "$lens" --zoom tele --field 2 --ghost "$pair" -o "ghost-path-$n.svg"
done

# ---- 5. Zoom and focus move the elements, the flare follows (abstract) ------------------------
first=""
# The patent's three positions by name (their EFLs are 80.0001, 139.9999 and 199.9999 mm: 80 and
# 200 by number would lie a hair outside the range) and two focal lengths between them.
for spec in wide:80 110:110 mid:140 170:170 tele:200; do
    z=${spec#*:}
    tools scene "scene-zoom-$z.json" --zoom "${spec%%:*}" --field 3,2 --f-number 4 --resolution "$res" \
        --description "zoom sweep: $z mm, f/4"
    extra=()
    [ -z "$first" ] || extra=(--exposure "$(exposure_of "$first")")
    render "zoom-$z" "abstract" "zoom sweep: $z mm, light at (3°, 2°), f/4" "scene-zoom-$z.json" $sweep "${extra[@]}"
    [ -n "$first" ] || first="zoom-$z"
done
first=""
for d in inf 10000 5000 2500; do
    tools scene "scene-focus-$d.json" --zoom tele --field 2,1.5 --f-number 4 --focus "$d" --resolution "$res" \
        --description "focus sweep: 200 mm, focused at $d mm, f/4"
    extra=()
    [ -z "$first" ] || extra=(--exposure "$(exposure_of "$first")")
    render "focus-$d" "abstract" "focus sweep: 200 mm focused at $([ "$d" = inf ] && echo infinity || echo "$d mm")" \
        "scene-focus-$d.json" $sweep "${extra[@]}"
    [ -n "$first" ] || first="focus-$d"
done

# ---- 6. The flare as an overlay over a frame (abstract; thesis 5.1's set-up) -------------------
# Two ways: a rendered flare merged over a generated frame (scripts/thesis_tools.py overlay, frame +
# flare pixel by pixel), and `flare composite`, which finds the bright sources of a plate (the
# sunlit plate of scripts/make-plates.py) and adds the flare they make through the lens.
"$py" "$root/scripts/make-plates.py" plates --width "${res%%,*}" >/dev/null
run composite "5.1" "flare composite: the sun of a sunlit plate through the 80-200 at 80 mm, f/4" - \
    composite.exr composite.png -- \
    "$flare" composite plates/sunlit.exr --lens "$lens" --zoom wide --f-number 4 -o composite.exr --png composite.png \
        $composite --quiet
run overlay "5.1" "the mid-field flare merged over a generated frame (frame + flare)" - \
    overlay.exr overlay.png overlay-frame.png -- \
    tools overlay --scene scene-position-midfield.json --flare-exr position-midfield.exr \
        --out-exr overlay.exr --out-png overlay.png --frame-png overlay-frame.png

# ---- 7. Coatings off (as in the thesis) against coated, and the ghost tables --------------------
tools scene scene-uncoated.json --zoom wide --field 6,4 --f-number 4 --coating none --resolution "$res" \
    --description "uncoated (the thesis's lenses), 80 mm, f/4"
render coating-none "5.2-5.12" "uncoated (as the thesis), 80 mm f/4, light at (6°, 4°)" scene-uncoated.json $study \
    --exposure "$(exposure_of position-midfield)"
tables=()
for z in wide mid tele; do
    run "ghost-table-$z" "5.2-5.12" "ghost table at $z (coated, light at 3°, 2°)" - "stdout:ghost-table-$z.json" -- \
        "$flare" ghosts "$lens" --zoom "$z" --field-deg 3,2 --json
    tables+=("$z, MgF2=ghost-table-$z.json")
done
run ghost-table-none "5.2-5.12" "ghost table at wide, uncoated (light at 3°, 2°)" - stdout:ghost-table-none.json -- \
    "$flare" ghosts scene-uncoated.json --field-deg 3,2 --json
tables+=("wide, uncoated=ghost-table-none.json")
tools ghosts ghost-tables.md "${tables[@]}"

tools gallery manifest.json gallery.md
tools check manifest.json --expect $((28 + n))
echo "thesis: results in $out (gallery.md, bounces.md, ghost-tables.md, manifest.json)"
