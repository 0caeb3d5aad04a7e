#!/usr/bin/env python3
"""Retraining a ridge policy on a whole DAgger dataset: `imitate dagger train` against
polars + NumPy on the same files, side by side in one run: time and peak memory.

Make the dataset first (10 million steps in rounds of 250 000), from the repository root:

    target/release/imitate bench dagger-scale --dataset /tmp/scale/ds
    python3 benches/dagger_scale_peer.py /tmp/scale/ds

The peer reads every round with polars (`scan_parquet`), turns the observations and
labels into NumPy arrays and solves the same standardised ridge regression.
"""

import argparse
import resource
import subprocess
import sys
import time


def peer(dataset, lam):
    import numpy as np
    import polars as pl

    frame = (
        pl.scan_parquet(f"{dataset}/data/round=*/part-000.parquet")
        .select("observation.state", pl.col("action").arr.first())
        .collect()
    )
    x = frame["observation.state"].to_numpy().astype(np.float64)
    y = frame["action"].to_numpy().astype(np.float64)
    mean, scale = x.mean(axis=0), x.std(axis=0)
    z = (x - mean) / scale
    a = z.T @ z / len(y) + lam * np.eye(z.shape[1])
    w = np.linalg.solve(a, z.T @ (y - y.mean()) / len(y))
    return len(y), w


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset")
    parser.add_argument("--imitate", default="target/release/imitate")
    args = parser.parse_args()

    start = time.perf_counter()
    subprocess.run(
        [args.imitate, "dagger", "train", args.dataset, "--out", f"{args.dataset}-policy"],
        check=True, capture_output=True)
    ours = time.perf_counter() - start
    ours_peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024

    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    start = time.perf_counter()
    rows, weights = peer(args.dataset, 1e-3)
    theirs = time.perf_counter() - start
    theirs_peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{rows} steps")
    print(f"imitate dagger train : {ours:7.2f} s, peak {ours_peak:8.0f} MB")
    print(f"polars + NumPy       : {theirs:7.2f} s, peak {theirs_peak:8.0f} MB "
          f"(interpreter and imports before reading: {before:.0f} MB)")
    print(f"ratio                : {theirs / ours:7.1f}x time, {theirs_peak / ours_peak:.1f}x memory")
    print("peer weights (standardised):", weights.round(4).tolist(), file=sys.stderr)


if __name__ == "__main__":
    main()
