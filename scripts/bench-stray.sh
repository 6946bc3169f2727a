#!/usr/bin/env bash
# Stray light sampling against the analog walk, in one run (docs/BENCHMARKS.md, "Stray light
# sampling"): for each scene and seed, `flare render --time T` with and without --analog-stray,
# alternately, then a table of the scatter layer's power, its standard error, the variance per
# unit time ratio, the render's own estimate of the scatter layer's and the flare's relative L2
# error, and the passes made. Needs a Release build in $FLARE_BUILD_DIR (default build/).
#
#   scripts/bench-stray.sh [SECONDS] [SEEDS] [SCENE...]    default: 20 s, seeds "1 2 3", the
#                                                          default scene and docs/examples/
#                                                          dusty-double-gauss.json, dirty-lens.json
set -euo pipefail
cd "$(dirname "$0")/.."
build="${FLARE_BUILD_DIR:-build}"
seconds="${1:-20}"
seeds="${2:-1 2 3}"
shift $(( $# > 2 ? 2 : $# ))
scenes=("$@")
[ ${#scenes[@]} -gt 0 ] || scenes=(default docs/examples/dusty-double-gauss.json docs/examples/dirty-lens.json)
out="${FLARE_BENCH_OUT:-out/bench/stray}"
mkdir -p "$out"
for scene in "${scenes[@]}"; do
  name=$(basename "$scene" .json)
  arg=(); [ "$scene" = default ] || arg=("$scene")
  for seed in $seeds; do
    for variant in sampled analog; do
      flag=(); [ "$variant" = analog ] && flag=(--analog-stray)
      "$build/src/flare" render "${arg[@]}" --time "$seconds" --target-error 0 --seed "$seed" --no-diffraction \
        --quiet "${flag[@]}" -o "$out/$name-$seed-$variant.exr" --report "$out/$name-$seed-$variant.json" >/dev/null
    done
  done
done
/usr/bin/python3 - "$out" "$seconds" "$seeds" "${scenes[@]}" <<'EOF'
import json, os, statistics, sys
out, seconds, seeds, scenes = sys.argv[1], sys.argv[2], sys.argv[3].split(), sys.argv[4:]
print(f"| scene | seed | sampling | passes | scatter power (W) | its std. error | scatter est. error | flare est. error | variance × time, analog / sampled |")
print("|---|---|---|---|---|---|---|---|---|")
for scene in scenes:
    name = os.path.basename(scene).removesuffix(".json")
    ratios = []
    for seed in seeds:
        r = {v: json.load(open(f"{out}/{name}-{seed}-{v}.json")) for v in ("sampled", "analog")}
        def vt(x):  # variance of the scatter power times the wall time
            s = x["layers"]["scatter"]
            return s["standard_error_w"] ** 2 * x["wall_time_s"]
        ratio = vt(r["analog"]) / vt(r["sampled"]) if vt(r["sampled"]) > 0 else float("inf")
        ratios.append(ratio)
        for v in ("sampled", "analog"):
            x = r[v]; s = x["layers"]["scatter"]
            print(f"| {name} | {seed} | {v} | {x['passes']} | {s['power_w']:.3g} | {s['standard_error_w']:.2g} | "
                  f"{s['estimated_relative_error']:.3f} | {x['flare_estimated_relative_error']:.3f} | "
                  f"{ratio:.1f} |" if v == "sampled" else
                  f"| {name} | {seed} | {v} | {x['passes']} | {s['power_w']:.3g} | {s['standard_error_w']:.2g} | "
                  f"{s['estimated_relative_error']:.3f} | {x['flare_estimated_relative_error']:.3f} | |")
    print(f"| {name} | median | | | | | | | {statistics.median(ratios):.1f} |")
EOF
echo "bench-stray: $seconds s per render; machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), load $(cut -d' ' -f1-3 /proc/loadavg)"
