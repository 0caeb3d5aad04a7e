#!/usr/bin/env bash
# Times the quickstart pipeline end to end (release build) with 1 and 2 rayon threads,
# best of N runs each (every stage forced to run: the cache would make later runs
# no-ops), and prints the parallel speed-up. Run from the repository root:
#   bash benches/quickstart.sh [RUNS]
set -euo pipefail
runs=${1:-5}
cargo build --release --quiet
bin=target/release/imitate
best() {
  local threads=$1 best=
  for _ in $(seq "$runs"); do
    local start end t
    start=$(date +%s.%N)
    RAYON_NUM_THREADS=$threads "$bin" run pipelines/quickstart.yaml --force >/dev/null 2>&1
    end=$(date +%s.%N)
    t=$(echo "$end - $start" | bc -l)
    if [ -z "$best" ] || (( $(echo "$t < $best" | bc -l) )); then best=$t; fi
  done
  echo "$best"
}
one=$(best 1)
two=$(best 2)
printf 'quickstart (every stage of pipelines/quickstart.yaml), best of %s runs\n' "$runs"
printf '  1 thread : %.3f s\n  2 threads: %.3f s\n  speed-up : %.2fx\n' "$one" "$two" "$(echo "$one / $two" | bc -l)"
