#!/usr/bin/env python3
"""Per-round statistics of a whole DAgger dataset: `imitate dagger status` (a polars scan
from Rust) against the same query in Python polars, side by side in one run: time and
peak memory, each in its own process.

The query: per round, the root mean square of (executed − teacher) over the learner's
steps and the mean and standard deviation of every observation value, streaming.
Make the dataset first (10 million steps), from the repository root:

    target/release/imitate bench dagger-scale --dataset /tmp/scale/ds
    python3 benches/dagger_status_peer.py /tmp/scale/ds
"""

import argparse
import json
import resource
import subprocess
import sys
import time

PEER = r"""
import json, resource, sys
import polars as pl
dataset, dims = sys.argv[1], int(sys.argv[2])
rounds = pl.read_parquet(f"{dataset}/meta/rounds.parquet")["round"].to_list()
files = [f"{dataset}/data/round={r:03}/part-000.parquet" for r in rounds]
executed = pl.col("action_executed").arr.get(0)
label = pl.col("action").arr.get(0)
obs = lambda k: pl.col("observation.state").arr.get(k).cast(pl.Float64)
aggs = [((executed - label) ** 2).cast(pl.Float64).filter(pl.col("actor") == "learner").mean().alias("mse")]
for k in range(dims):
    aggs += [obs(k).mean().alias(f"mean_{k}"), obs(k).std().alias(f"std_{k}")]
table = (pl.scan_parquet(files, hive_partitioning=False).group_by("round").agg(aggs)
         .sort("round").collect(engine="streaming"))
print(json.dumps({"rounds": table.height, "mean_0": table["mean_0"].to_list(),
                  "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset")
    parser.add_argument("--imitate", default="target/release/imitate")
    args = parser.parse_args()
    info = json.load(open(f"{args.dataset}/meta/info.json"))
    dims = len(info["observation_names"])

    start = time.perf_counter()
    ours_out = subprocess.run([args.imitate, "dagger", "status", args.dataset, "--json"],
                              check=True, capture_output=True, text=True).stdout
    ours = time.perf_counter() - start
    ours_peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024

    start = time.perf_counter()
    peer_out = subprocess.run([sys.executable, "-c", PEER, args.dataset, str(dims)],
                              check=True, capture_output=True, text=True).stdout
    theirs = time.perf_counter() - start
    peer = json.loads(peer_out)
    ours_rounds = json.loads(ours_out)
    rounds = len(ours_rounds)
    assert rounds == peer["rounds"], (rounds, peer["rounds"])
    # The same statistics: the first observation value's mean per round.
    worst = max(abs(r["observation_mean"][0] - m) for r, m in zip(ours_rounds, peer["mean_0"]))
    assert worst < 1e-9, worst
    print(f"{rounds} rounds")
    print(f"imitate dagger status : {ours:7.2f} s, peak {ours_peak:8.0f} MB")
    print(f"Python polars         : {theirs:7.2f} s, peak {peer['peak_mb']:8.0f} MB "
          f"(interpreter start and import included)")
    print(f"ratio                 : {theirs / ours:7.2f}x time, "
          f"{peer['peak_mb'] / ours_peak:.2f}x memory")


if __name__ == "__main__":
    main()
