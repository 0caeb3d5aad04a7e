#!/usr/bin/env bash
# Held-out agreement of the LEARCH variants on the quickstart world, one table.
# Run from the repository root after `cargo build --release`:
#   bash benches/learch_methods.sh
set -euo pipefail
imitate="$PWD/target/release/imitate"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
cp -r testdata "$work/"
cd "$work"
maps=() refs=()
for i in 0 1 2 3; do
  maps+=(--map "testdata/world/maps/terrain-00$i.parquet")
  refs+=(--reference "testdata/world/truth/terrain-00$i.parquet")
done
"$imitate" ingest "${maps[@]}" --demonstrations testdata/world/demonstrations.parquet --out ds 2>/dev/null >/dev/null
"$imitate" features --dataset ds --out fs 2>/dev/null >/dev/null
echo "| weak learner | loss | early stopping (patience) | rounds kept | within 2 cells | mean cost ratio | max cost ratio | seconds |"
echo "|---|---|---|---|---|---|---|---|"
for learner in ridge tree; do
  for loss in hamming dilated; do
    for patience in none 5; do
      extra=()
      [ "$patience" != none ] && extra=(--patience "$patience" --validation 0.25 --rounds 80)
      start=$(date +%s.%N)
      "$imitate" learch --dataset ds --features fs --weak-learner "$learner" --loss-kind "$loss" \
        "${refs[@]}" "${extra[@]}" --out "c-$learner-$loss-$patience" 2>/dev/null >/dev/null
      end=$(date +%s.%N)
      python3 - "$learner" "$loss" "$patience" "c-$learner-$loss-$patience/metrics.json" "$start" "$end" <<'PY'
import json, sys
learner, loss, patience, path, start, end = sys.argv[1:]
m = json.load(open(path))
h = m["holdout"]["summary"]
print(f"| {learner} | {loss} | {patience} | {m['kept_round']} | {100 * h['within_radius']:.1f} % | "
      f"{h['mean_reference_cost_ratio']:.3f} | {h['max_reference_cost_ratio']:.3f} | {float(end) - float(start):.2f} |")
PY
    done
  done
done
