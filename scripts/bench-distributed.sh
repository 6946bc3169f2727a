#!/usr/bin/env bash
# Distributed render scaling on this machine (docs/scaling.md): the same image rendered by one
# process with 1 and 2 threads and by 2 MPI ranks of 1 thread each, the runs interleaved (so that
# the machine's load hits every configuration alike), REPEATS times; prints each run's pass time
# (the report's wall_time_s: the passes, without the start-up), whole-run time and CPU time (user +
# system, all processes, GNU time), the medians, the load average before and after, and the
# 2-rank runs' per-pass costs as flare render prints them (wall / CPU s of each part), and the
# ratios taken within each round (their median and range): on a shared VM the machine's speed moves
# between rounds by more than the differences sought.
# Usage: scripts/bench-distributed.sh [build/src/flare] [repeats] [photons] [extra render options...]
# With BASELINE=path/to/another/flare, its 2-rank runs join the rounds (ranks2-base), so that a
# change is measured before and after under the same load.
# The rounds also run `pair`: two independent 1-thread renders of the same image at once, i.e. two
# processes that share no work. 2 x threads1 / pair is what this machine gives two such processes
# (its shared caches, memory bandwidth, clocks with both cores busy); the 2-rank runs' shortfall
# from it, and their CPU above the pair's, is the sharing's own cost. (Two threads share one film's
# caches and can do better than the pair.)
set -euo pipefail
flare=${1:-build/src/flare}
repeats=${2:-3}
photons=${3:-1048576}
shift $(( $# < 3 ? $# : 3 ))
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
# Ranks waiting for rank 0 yield their core rather than spin (the machine may be shared).
mpirun=(mpirun --allow-run-as-root --oversubscribe --mca mpi_yield_when_idle 1)
common=(--photons "$photons" --target-error 0 --no-diffraction "$@")

declare -A runs=(
  [threads1]="$flare render -o $out/x.exr --report $out/r.json --threads 1 ${common[*]}"
  [threads2]="$flare render -o $out/x.exr --report $out/r.json --threads 2 ${common[*]}"
  [ranks2]="${mpirun[*]} -np 2 --bind-to core $flare render -o $out/x.exr --report $out/r.json --threads 1 ${common[*]}"
)
order=(threads1 threads2 ranks2 pair)
if [[ -n ${BASELINE:-} ]]; then
  runs[ranks2-base]="${mpirun[*]} -np 2 --bind-to core $BASELINE render -o $out/x.exr --report $out/r.json --threads 1 ${common[*]}"
  order+=(ranks2-base)
fi
echo "load before: $(uptime)"
for ((i = 0; i < repeats; i++)); do
  for name in "${order[@]}"; do
    start=$(date +%s.%N)
    if [[ $name == pair ]]; then
      for k in a b; do
        /usr/bin/time -f "%U %S" -o "$out/cpu-$k" $flare render -o "$out/pair-$k.exr" --report "$out/r-$k.json" \
          --threads 1 "${common[@]}" >/dev/null 2>"$out/err-$k" &
      done
      wait
      end=$(date +%s.%N)
      : >"$out/err"  # (no per-pass line of ranks to print)
      cp "$out/pair-b.exr" "$out/pairb-$i.exr"
      cp "$out/pair-a.exr" "$out/x.exr"
      passes=$(python3 -c "import json; print(max(json.load(open(f'$out/r-{k}.json'))['wall_time_s'] for k in 'ab'))")
      cpu=$(python3 -c "print(sum(sum(map(float, open(f'$out/cpu-{k}').read().split()[-2:])) for k in 'ab'))")
    else
      /usr/bin/time -f "%U %S" -o "$out/cpu" ${runs[$name]} >/dev/null 2>"$out/err"
      end=$(date +%s.%N)
      passes=$(python3 -c "import json; print(json.load(open('$out/r.json'))['wall_time_s'])")
      cpu=$(python3 -c "u, s = open('$out/cpu').read().split()[-2:]; print(float(u) + float(s))")
    fi
    echo "$name $passes $(python3 -c "print($end - $start)") $cpu" | tee -a "$out/times"
    grep -o "ranks, per pass.*" "$out/err" || true
    cp "$out/x.exr" "$out/$name-$i.exr"
  done
done
echo "load after: $(uptime)"
# Every run made the same image, bit for bit.
for f in "$out"/*-*.exr; do cmp -s "$f" "$out/threads1-0.exr" || { echo "bench: $f differs" >&2; exit 1; }; done
python3 - "$out/times" <<'PY'
import statistics, sys
rows = [line.split() for line in open(sys.argv[1])]
med = {}
names = [n for n in ("threads1", "threads2", "ranks2", "ranks2-base", "pair") if any(r[0] == n for r in rows)]
for name in names:
    passes = [float(r[1]) for r in rows if r[0] == name]
    total = [float(r[2]) for r in rows if r[0] == name]
    cpu = [float(r[3]) for r in rows if r[0] == name]
    med[name] = (statistics.median(passes), statistics.median(total), statistics.median(cpu))
    print(f"{name:9s} passes {med[name][0]:7.2f} s   whole run {med[name][1]:7.2f} s   CPU {med[name][2]:7.2f} s"
          f"   (median of {len(passes)})")
for name in names[1:]:
    images = 2 if name == "pair" else 1  # the pair makes two images in its time
    print(f"speed-up of {name} over threads1: passes {images * med['threads1'][0] / med[name][0]:.2f}x, "
          f"whole run {images * med['threads1'][1] / med[name][1]:.2f}x"
          + ("  (two processes sharing no work)" if name == "pair" else ""))
# The same round's ratios: the runs of a round are minutes apart at most, where the machine's speed
# may move by more than the differences sought between rounds (a shared VM).
passes = {name: [float(r[1]) for r in rows if r[0] == name] for name in names}
rounds = min(len(v) for v in passes.values())
def spread(ratios):
    return f"median {statistics.median(ratios):.2f}x (rounds {min(ratios):.2f}-{max(ratios):.2f}x)"
for name in names[1:]:
    images = 2 if name == "pair" else 1
    print(f"same-round passes speed-up of {name} over threads1: "
          + spread([images * passes['threads1'][i] / passes[name][i] for i in range(rounds)]))
if "ranks2-base" in passes:
    print("same-round passes of ranks2 / ranks2-base: "
          + spread([passes['ranks2'][i] / passes['ranks2-base'][i] for i in range(rounds)]).replace("x", ""))
PY
