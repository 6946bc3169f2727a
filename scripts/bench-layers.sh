#!/bin/bash
# Per-ghost layers (docs/BENCHMARKS.md, issue 28 item 1): the preview of
# docs/examples/nikon-70-200-sun.json with and without per-ghost layers, its wall time, CPU time and
# peak memory (GNU time's maximum resident set size) and the EXR's size, for two builds.
# Usage: scripts/bench-layers.sh BEFORE_BUILD AFTER_BUILD [RUNS]
#   each build folder holding src/flare and python/ (e.g. build-before/ and build/).
set -u
before=${1:?usage: scripts/bench-layers.sh BEFORE_BUILD AFTER_BUILD [RUNS]}
after=${2:?usage: scripts/bench-layers.sh BEFORE_BUILD AFTER_BUILD [RUNS]}
runs=${3:-2}
scene=$(cd "$(dirname "$0")/.." && pwd)/docs/examples/nikon-70-200-sun.json
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
measure() {  # label, command...
  local label=$1; shift
  /usr/bin/time -f "%e %U %S %M" -o $out/time.txt "$@" > /dev/null 2> $out/err.txt || { echo "$label FAILED"; cat $out/err.txt; }
  read wall user sys rss < $out/time.txt
  printf "%-34s wall %6.1f s  user+sys %6.1f s  max RSS %6.0f MB\n" "$label" $wall $(echo "$user + $sys" | bc) $(echo "$rss / 1024" | bc)
}
for run in $(seq "$runs"); do
  echo "== run $run $(uptime)"
  measure "before --layers"            "$before/src/flare" preview $scene -o $out/before.exr --layers --quiet
  ls -l $out/before.exr | awk '{printf "  EXR %.1f MB\n", $5/1e6}'
  measure "after --layers"             "$after/src/flare" preview $scene -o $out/after.exr --layers --quiet
  ls -l $out/after.exr | awk '{printf "  EXR %.1f MB\n", $5/1e6}'
  measure "after --layers share:0.9"   "$after/src/flare" preview $scene -o $out/share.exr --layers share:0.9 --quiet
  ls -l $out/share.exr | awk '{printf "  EXR %.1f MB\n", $5/1e6}'
  measure "after --layers top:20"      "$after/src/flare" preview $scene -o $out/top.exr --layers top:20 --quiet
  ls -l $out/top.exr | awk '{printf "  EXR %.1f MB\n", $5/1e6}'
  measure "before, no layers"          "$before/src/flare" preview $scene -o $out/plain-before.exr --quiet
  measure "after, no layers"           "$after/src/flare" preview $scene -o $out/plain-after.exr --quiet
  measure "python before layers=True"  env PYTHONPATH="$before/python" /usr/bin/python3 -c "import flare; flare.preview(flare.load_scene('$scene'), layers=True)"
  measure "python after layers=True"   env PYTHONPATH="$after/python" /usr/bin/python3 -c "import flare; flare.preview(flare.load_scene('$scene'), layers=True)"
done
