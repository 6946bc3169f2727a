#!/usr/bin/env bash
# Set-up if needed, build, and run the main job on the embedded default scene (a sun 13.5° off
# axis through the 50 mm double Gauss at f/4): the per-ghost table, the noise-free flare preview
# (layered EXR and PNG), the physically based photon render (layered EXR, PNG and a JSON report
# with per-ghost power and standard errors) and a cutaway drawing of the lens. Prints where the
# output went.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh >/dev/null
mkdir -p out
build/src/flare ghosts docs/examples/default.json > out/default-ghosts.txt
sed -n '1,20p' out/default-ghosts.txt
build/src/flare ghosts docs/examples/default.json --json > out/default-ghosts.json
build/src/flare preview -o out/default.exr --png out/default.png
# To the default target (2 % estimated error of the flare without the direct image), at most 60 s:
# about 23 s of passes on two cores (docs/BENCHMARKS.md).
build/src/flare render --time 60 -o out/default-render.exr --png out/default-render.png --report out/default-render.json
build/src/flare lens draw double-gauss-50mm -o out/double-gauss-50mm.svg --rays 11
echo
echo "output in $(pwd)/out:"
echo "  default.exr          preview (the final render's first two passes of beams, no photons) with the
                       sun's diffraction starburst, linear Rec.709 (add --layers for"
echo "                       direct, starburst, ghost and one layer per ghost)"
echo "  default.png          tone-mapped preview"
echo "  default-render.exr   final render (ghosts by beams, the rest by photons; to 2 % estimated error"
echo "                       or 60 s): main image and the layers"
echo "                       direct, ghost, higher, scatter, starburst and variance"
echo "  default-render.png   tone-mapped render"
echo "  default-render.json  render report: per-ghost power with standard errors, each layer's estimated"
echo "                       error, energy"
echo "  default-ghosts.txt   per-ghost table (paraxial ghost focus, power, footprint)"
echo "  default-ghosts.json  the same as JSON"
echo "  double-gauss-50mm.svg  lens cutaway with ray fans"
