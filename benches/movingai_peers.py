#!/usr/bin/env python3
"""MovingAI grid benchmarks: imitate's Dijkstra and A* against SciPy's Dijkstra, same
scenarios, same machine, one thread, side by side in one run.

The graph follows the benchmark's semantics in all of them: 8-connected, diagonal steps
of length sqrt 2 only where both orthogonal neighbours are passable, '.', 'G' and 'S'
passable. SciPy's CSR graph is built before its clock starts. SciPy's Dijkstra cannot
stop at a target; its `limit` argument, set to the query's optimal length (plus the
1e-4 tolerance: the files round their lengths), makes it settle about what a Dijkstra
that stops at the goal settles. Every answer
is checked against the scenario's optimal length (relative tolerance 1e-4). Run from the
repository root after `cargo build --release`:

    python3 benches/movingai_peers.py MAP SCEN [--every K]
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

PASSABLE = set(".GS")


def read_map(path):
    lines = open(path).read().splitlines()
    height = int(lines[1].split()[1])
    width = int(lines[2].split()[1])
    rows = lines[4:4 + height]
    return np.array([[ch in PASSABLE for ch in row[:width]] for row in rows])


def grid_graph(open_):
    """CSR matrix of the grid under the benchmark's rules; node = y * width + x."""
    h, w = open_.shape
    index = np.arange(h * w).reshape(h, w)
    rows, cols, weights = [], [], []
    for dy, dx in [(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)]:
        y0, y1 = max(0, -dy), min(h, h - dy)
        x0, x1 = max(0, -dx), min(w, w - dx)
        ok = open_[y0:y1, x0:x1] & open_[y0 + dy:y1 + dy, x0 + dx:x1 + dx]
        if dy and dx:  # no corner cutting
            ok &= open_[y0 + dy:y1 + dy, x0:x1] & open_[y0:y1, x0 + dx:x1 + dx]
        a = index[y0:y1, x0:x1][ok]
        b = index[y0 + dy:y1 + dy, x0 + dx:x1 + dx][ok]
        rows.append(a); cols.append(b)
        weights.append(np.full(a.size, np.sqrt(2.0) if dy and dx else 1.0))
    n = h * w
    return scipy.sparse.csr_matrix(
        (np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))


def imitate(binary, map_path, scen_path, planner, env):
    out = subprocess.run([binary, "bench", "movingai", map_path, scen_path, "--planner", planner,
                          "--json"], check=True, capture_output=True, text=True, env=env)
    return json.loads(out.stdout)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("map")
    parser.add_argument("scen")
    parser.add_argument("--every", type=int, default=1, help="use every K-th scenario")
    parser.add_argument("--imitate", default="target/release/imitate")
    args = parser.parse_args()
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", RAYON_NUM_THREADS="1")

    lines = open(args.scen).read().splitlines()
    chosen = [line for line in lines[1:] if line.strip()][::args.every]
    with tempfile.NamedTemporaryFile("w", suffix=".scen") as scen:
        scen.write("\n".join([lines[0]] + chosen) + "\n")
        scen.flush()
        ours = {p: imitate(args.imitate, args.map, scen.name, p, env) for p in ("dijkstra", "astar")}

    open_ = read_map(args.map)
    width = open_.shape[1]
    graph = grid_graph(open_)
    mismatches, elapsed = 0, 0.0
    for line in chosen:
        f = line.split("\t")
        sx, sy, gx, gy, optimal = int(f[4]), int(f[5]), int(f[6]), int(f[7]), float(f[8])
        start = time.perf_counter()
        dist = scipy.sparse.csgraph.dijkstra(graph, indices=sy * width + sx,
                                             limit=optimal * (1 + 1e-4))
        elapsed += time.perf_counter() - start
        if abs(dist[gy * width + gx] - optimal) > 1e-4 * max(optimal, 1e-9):
            mismatches += 1
    scipy_us = elapsed / len(chosen) * 1e6

    print(f"{os.path.basename(args.map)}: {len(chosen)} scenarios")
    print(f"{'planner':<28} {'mismatches':>10} {'us/query':>10} {'vs SciPy':>9}")
    print(f"{'scipy dijkstra (limit)':<28} {mismatches:>10} {scipy_us:>10.1f} {'':>9}")
    for planner, report in ours.items():
        us = report["microseconds_per_query"]
        print(f"{'imitate ' + planner:<28} {report['mismatches']:>10} {us:>10.1f} "
              f"{scipy_us / us:>8.1f}x")


if __name__ == "__main__":
    main()
