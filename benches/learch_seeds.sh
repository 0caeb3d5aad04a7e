#!/usr/bin/env bash
# Held-out quality of LEARCH over several synthetic worlds (the quickstart's kind, other
# seeds). Run from the repository root:
#   bash benches/learch_seeds.sh [FIRST_SEED LAST_SEED]
set -euo pipefail
first=${1:-1}
last=${2:-8}
cargo build --release --quiet
bin=$PWD/target/release/imitate
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
printf 'seed\theld-out\twithin 2 cells\tmean cost ratio\tmax cost ratio\n'
for seed in $(seq "$first" "$last"); do
  cd "$work" && rm -rf ./*
  "$bin" testdata world --out w --seed "$seed" 2>/dev/null
  maps=() refs=()
  for f in w/maps/*.parquet; do maps+=(--map "$f"); done
  for f in w/truth/*.parquet; do refs+=(--reference "$f"); done
  "$bin" ingest "${maps[@]}" --demonstrations w/demonstrations.parquet --out ds >/dev/null 2>&1
  "$bin" features --dataset ds --out f >/dev/null 2>&1
  "$bin" learch --dataset ds --features f --out c "${refs[@]}" >/dev/null 2>&1
  python3 - "$seed" <<'PY'
import json, sys
s = json.load(open("c/metrics.json"))["holdout"]["summary"]
print(f"{sys.argv[1]}\t{s['examples']}\t{100 * s['within_radius']:.1f} %\t{s['mean_reference_cost_ratio']:.3f}\t{s['max_reference_cost_ratio']:.3f}")
PY
done
