#!/usr/bin/env python3
"""Single-source Dijkstra over a whole 8-connected costmap: imitate against SciPy and
scikit-image, same grid, same machine, one thread, side by side in one run.

Costs are uniform in [1, 10] (seeded NumPy); the edge cost between neighbours is the step
length (1 or sqrt 2) times the mean of the two cells' costs, in all three. SciPy's graph is
built before the clock starts. Every implementation's cost field is checked against
SciPy's. Run from the repository root after `cargo build --release`:

    python3 benches/dijkstra_peers.py [--sizes 1000 4000] [--repeat 5]
"""

import argparse
import json
import os
import subprocess
import tempfile
import time

import numpy as np
import scipy.sparse
import scipy.sparse.csgraph
from skimage.graph import MCP_Geometric


def grid_graph(costs):
    """CSR matrix of the 8-connected grid with edge cost length * mean of the cells."""
    h, w = costs.shape
    index = np.arange(h * w).reshape(h, w)
    rows, cols, weights = [], [], []
    for dr, dc in [(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)]:
        r0, r1 = max(0, -dr), min(h, h - dr)
        c0, c1 = max(0, -dc), min(w, w - dc)
        a = index[r0:r1, c0:c1]
        b = index[r0 + dr:r1 + dr, c0 + dc:c1 + dc]
        length = np.sqrt(2.0) if dr and dc else 1.0
        wgt = length * 0.5 * (costs[r0:r1, c0:c1].astype(np.float64) + costs[r0 + dr:r1 + dr, c0 + dc:c1 + dc])
        rows.append(a.ravel()); cols.append(b.ravel()); weights.append(wgt.ravel())
    n = h * w
    return scipy.sparse.csr_matrix(
        (np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))


def best_of(repeat, fn):
    times, result = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - start)
    return min(times), result


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 4000])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--imitate", default="target/release/imitate")
    args = parser.parse_args()
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", RAYON_NUM_THREADS="1")
    print(f"{'size':>6} {'imitate s':>10} {'scipy s':>9} {'skimage s':>10} {'vs scipy':>9} {'vs skimage':>11}  max rel. diff")
    for size in args.sizes:
        rng = np.random.default_rng(size)
        costs = rng.uniform(1.0, 10.0, size=(size, size)).astype(np.float32)
        with tempfile.NamedTemporaryFile(suffix=".f32") as f:
            costs.tofile(f.name)
            out = subprocess.run(
                [args.imitate, "bench", "dijkstra", "--costs", f.name, "--width", str(size),
                 "--height", str(size), "--repeat", str(args.repeat), "--json"],
                check=True, capture_output=True, text=True, env=env)
        ours = json.loads(out.stdout)
        graph = grid_graph(costs)
        repeat = args.repeat if size <= 2000 else max(1, args.repeat // 2)
        t_scipy, dist = best_of(repeat, lambda: scipy.sparse.csgraph.dijkstra(graph, indices=0))
        mcp_costs = costs.astype(np.float64)
        t_skimage, (field, _) = best_of(repeat, lambda: MCP_Geometric(mcp_costs).find_costs([(0, 0)]))
        reference = dist.sum()
        diff = max(abs(ours["cost_sum"] - reference) / reference,
                   abs(field.sum() - reference) / reference)
        print(f"{size:>6} {ours['best_seconds']:>10.4f} {t_scipy:>9.4f} {t_skimage:>10.4f} "
              f"{t_scipy / ours['best_seconds']:>8.1f}x {t_skimage / ours['best_seconds']:>10.1f}x  {diff:.1e}")


if __name__ == "__main__":
    main()
