#!/usr/bin/env python3
"""One LEARCH round: imitate against a NumPy/SciPy implementation of the same round, on
the same maps, features, examples, loss and ridge fit, side by side in one run.

imitate makes the inputs: a synthetic world (`imitate testdata world`, 4 maps of
--size², --examples demonstrations), its dataset and 16 features (the spec of `imitate
bench learch`: the 4 layers, blurs, slope, roughness, distances, a product, the bias).
Then:

- imitate: `imitate learch --weak-learner ridge --holdout 0` (and `tree`, timed beside
  the same ridge peer) with 1 and with 1 + R
  rounds, at 1 and at all threads; a round's time is the difference over R (setup and
  the final evaluation cancel; with nothing held out no round plans held-out paths for
  the learning curves).
- the peer, with as many worker processes as imitate has threads: each worker loads
  the features once and holds the CSR graph of the 8-connected grid (built once; each
  plan sets its weights: step length × the mean of the two cells' loss-augmented
  costs); per round every training example's costmap exp(w·x / scale), the Hamming
  loss (cost × 0.7 off the demonstration, floored at 1e-6), SciPy's csgraph Dijkstra
  from the start, the path from its predecessors, and the visit differences' ridge
  moments (NumPy); the driver solves the ridge system (λ 1e-3) and takes the step
  1/√t, as imitate does.

Rounds are timed on every example. Then both learn on imitate's split (a quarter held
out, the episodes its metrics list) and print the held-out share of planned cells
within 2 cells of the demonstration after 1 + R rounds, so the two are seen to learn
the same thing. Run from the repository root:

    scripts/python-deps.sh && cargo build --release
    PYTHONPATH=target/python-deps python3 benches/learch_peer.py [--size 512] \\
        [--examples 64] [--rounds 3] [--threads 2]
"""

import argparse
import glob
import json
import math
import multiprocessing
import os
import subprocess
import tempfile
import time

import numpy as np
import pyarrow.parquet as pq
import scipy.sparse
import scipy.sparse.csgraph

# The binary to time (IMITATE overrides it, e.g. to time an earlier build).
IMITATE = os.environ.get("IMITATE") or os.path.abspath(
    os.path.join(os.path.dirname(__file__), "..", "target", "release", "imitate"))
LOSS, FLOOR, LAMBDA, LOG_COST_LIMIT = 0.3, 1e-6, 1e-3, 40.0
OPS = [
    {"op": "blur", "layer": "elevation", "sigmas": [2, 8]},
    {"op": "slope", "layer": "elevation"},
    {"op": "roughness", "layer": "elevation", "windows": [7]},
    {"op": "blur", "layer": "vegetation", "sigmas": [2, 8]},
    {"op": "distance", "layer": "water", "above": 0.5},
    {"op": "blur", "layer": "water", "sigmas": [4]},
    {"op": "distance", "layer": "road", "class": 1},
    {"op": "blur", "layer": "road", "sigmas": [4]},
    {"op": "product", "a": "vegetation", "b": "elevation/slope_deg"},
]
MOVES = [(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)]


def imitate(*args, threads=None):
    env = dict(os.environ)
    if threads:
        env["RAYON_NUM_THREADS"] = str(threads)
    run = subprocess.run([IMITATE, *args], capture_output=True, text=True, env=env)
    if run.returncode != 0:
        raise SystemExit(f"imitate {' '.join(args)}: {run.stderr}")


def make_inputs(work, size, examples):
    world = os.path.join(work, "world")
    imitate("testdata", "world", "--out", world, "--maps", "4", "--width", str(size),
            "--height", str(size), "--demonstrations-per-map", str(math.ceil(examples / 4)))
    ingest = ["ingest", "--demonstrations", os.path.join(world, "demonstrations.parquet")]
    for m in sorted(glob.glob(os.path.join(world, "maps", "*.parquet"))):
        ingest += ["--map", m]
    imitate(*ingest, "--out", os.path.join(work, "ds"))
    features = ["features", "--dataset", os.path.join(work, "ds"), "--out",
                os.path.join(work, "fs")]
    for layer in ["elevation", "vegetation", "water", "road"]:
        features += ["--layer", layer]
    for op in OPS:
        features += ["--op", json.dumps(op)]
    imitate(*features)


def load_maps(work):
    """name -> (features [cells, F] float32, height, width, resolution)."""
    maps = {}
    for path in sorted(glob.glob(os.path.join(work, "fs", "features", "*.parquet"))):
        geo = json.loads(pq.ParquetFile(path).metadata.metadata[b"imitate.raster"])
        table = pq.read_table(path)
        names = [n for n in table.column_names if n not in ("row", "col")]
        x = np.stack([table.column(n).to_numpy().astype(np.float32) for n in names], axis=1)
        g = geo["geo"]
        maps[geo["name"]] = (x, g["height"], g["width"], g["resolution"])
    return maps


def load_paths(work):
    table = pq.read_table(os.path.join(work, "ds", "paths.parquet")).to_pydict()
    paths = {}
    for episode, name, row, col in zip(table["episode"], table["map"], table["row"],
                                       table["col"]):
        paths.setdefault(episode, (name, []))[1].append((row, col))
    return paths


def scales(maps):
    """Each feature's population standard deviation over every cell (1 where constant)."""
    x = np.concatenate([m[0] for m in maps.values()]).astype(np.float64)
    mean, sd = x.mean(axis=0), x.std(axis=0)
    return np.where(sd > 1e-6 * np.maximum(np.abs(mean), 1.0), sd, 1.0)


def grid_graph(height, width, resolution):
    """The 8-connected grid's CSR structure, and per edge its two cells and length."""
    index = np.arange(height * width).reshape(height, width)
    heads, tails, lengths = [], [], []
    for dr, dc in MOVES:
        r0, r1 = max(0, -dr), min(height, height - dr)
        c0, c1 = max(0, -dc), min(width, width - dc)
        heads.append(index[r0:r1, c0:c1].ravel())
        tails.append(index[r0 + dr:r1 + dr, c0 + dc:c1 + dc].ravel())
        lengths.append(np.full(heads[-1].size, resolution * (math.sqrt(2) if dr and dc else 1)))
    heads, tails, lengths = map(np.concatenate, (heads, tails, lengths))
    # Built with each edge's number (from 1) as its weight, to see where each edge's
    # weight lands in the CSR data (the matrix sorts its entries).
    numbers = np.arange(1, heads.size + 1, dtype=np.float64)
    graph = scipy.sparse.csr_matrix((numbers, (heads, tails)), shape=(height * width,) * 2)
    order = graph.data.astype(np.int64) - 1
    return graph, heads[order], tails[order], lengths[order]


WORKER = {}


def worker_init(maps, scale):
    WORKER["maps"] = maps
    WORKER["scale"] = scale
    WORKER["graphs"] = {name: grid_graph(h, w, res) for name, (_, h, w, res) in maps.items()}


def costmap(name, weights):
    x = WORKER["maps"][name][0]
    return np.exp(np.clip(x.astype(np.float64) @ weights, -LOG_COST_LIMIT,
                          LOG_COST_LIMIT)).astype(np.float32)


def plan(name, costs, start, goal):
    graph, heads, tails, lengths = WORKER["graphs"][name]
    c = costs.astype(np.float64)
    graph.data = lengths * 0.5 * (c[heads] + c[tails])
    _, predecessors = scipy.sparse.csgraph.dijkstra(graph, indices=start,
                                                    return_predecessors=True)
    path, node = [goal], goal
    while node != start:
        node = predecessors[node]
        path.append(node)
    return path[::-1]


def example_moments(job):
    """The ridge moments of one training example's visit differences."""
    name, cells, weights = job
    x, h, w, _ = WORKER["maps"][name]
    costs = costmap(name, weights)
    demo = np.array([r * w + c for r, c in cells])
    augmented = np.maximum(costs - np.float32(LOSS) * costs, np.float32(FLOOR))
    augmented[demo] = costs[demo]
    planned = plan(name, augmented, demo[0], demo[-1])
    visits = np.zeros(h * w, dtype=np.int64)
    np.add.at(visits, demo, -1)
    np.add.at(visits, planned, 1)
    cells = np.nonzero(visits)[0]
    xs = x[cells].astype(np.float64) / WORKER["scale"]
    target = np.sign(visits[cells]).astype(np.float64)
    weight = np.abs(visits[cells]).astype(np.float64)
    return xs.T @ (xs * weight[:, None]), xs.T @ (weight * target), weight.sum()


def within_two(job):
    """Planned cells of a held-out example and how many lie within 2 cells of its
    demonstration (Chebyshev distance)."""
    name, cells, weights = job
    _, h, w, _ = WORKER["maps"][name]
    demo = np.array([r * w + c for r, c in cells])
    planned = plan(name, costmap(name, weights), demo[0], demo[-1])
    near = np.zeros((h + 4, w + 4), dtype=bool)
    rows, cols = demo // w + 2, demo % w + 2
    for dr in range(-2, 3):
        for dc in range(-2, 3):
            near[rows + dr, cols + dc] = True
    planned = np.array(planned)
    return planned.size, int(near[planned // w + 2, planned % w + 2].sum())


def peer(maps, paths, training, holdout, rounds, processes):
    """Per-round seconds of training on `training`, then the held-out agreement."""
    scale = scales(maps)
    dims = next(iter(maps.values()))[0].shape[1]
    weights = np.zeros(dims)  # raw weights: log cost = x · weights
    times = []
    with multiprocessing.Pool(processes, worker_init, (maps, scale)) as pool:
        for t in range(rounds):
            began = time.perf_counter()
            jobs = [(paths[e][0], paths[e][1], weights) for e in training]
            a, b, total = np.zeros((dims, dims)), np.zeros(dims), 0.0
            for xtwx, xtwy, w in pool.map(example_moments, jobs, chunksize=1):
                a += xtwx
                b += xtwy
                total += w
            if total > 0:
                beta = np.linalg.solve(a / total + LAMBDA * np.eye(dims), b / total)
                weights = weights + beta / math.sqrt(t + 1) / scale
            times.append(time.perf_counter() - began)
        counts = pool.map(within_two, [(paths[e][0], paths[e][1], weights) for e in holdout])
    planned = sum(c[0] for c in counts)
    return times, sum(c[1] for c in counts) / planned if planned else float("nan")


def imitate_learch(work, rounds, threads, holdout, learner="ridge"):
    out = os.path.join(work, f"costmap-{learner}-{threads}-{rounds}-{holdout}")
    began = time.perf_counter()
    imitate("learch", "--dataset", os.path.join(work, "ds"), "--features",
            os.path.join(work, "fs"), "--out", out, "--rounds", str(rounds),
            "--weak-learner", learner, "--holdout", str(holdout), threads=threads)
    return time.perf_counter() - began, out


def imitate_round(work, rounds, threads, learner):
    """Seconds per round of training on every example (1 + rounds against 1 round,
    nothing held out, so no round evaluates held-out plans)."""
    one, _ = imitate_learch(work, 1, threads, 0, learner)
    more, _ = imitate_learch(work, 1 + rounds, threads, 0, learner)
    return (more - one) / rounds


def imitate_agreement(work, rounds):
    """The held-out agreement after `rounds` rounds with a quarter held out, and the
    held-out episodes."""
    _, out = imitate_learch(work, rounds, None, 0.25)
    with open(os.path.join(out, "metrics.json")) as f:
        metrics = json.load(f)
    held = [e["example"] for e in metrics["holdout"]["examples"]]
    return metrics["holdout"]["summary"]["within_radius"], held


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--examples", type=int, default=64)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--threads", type=int, default=os.cpu_count())
    args = parser.parse_args()
    work = tempfile.mkdtemp(prefix="imitate-learch-peer-")
    make_inputs(work, args.size, args.examples)
    maps, paths = load_maps(work), load_paths(work)
    print(f"4 maps of {args.size}², {len(paths)} demonstrations, "
          f"{next(iter(maps.values()))[0].shape[1]} features; 1 + {args.rounds} rounds")
    agreement, held = imitate_agreement(work, 1 + args.rounds)
    held = set(held)
    training = [e for e in sorted(paths) if e not in held]
    holdout = [e for e in sorted(paths) if e in held]
    rows = [(f"imitate, ridge, {threads} thread(s)",
             imitate_round(work, args.rounds, threads, "ridge"), agreement)
            for threads in sorted({1, args.threads})]
    # Trees (depth 3) fit another learner on the same plans: the round is timed beside
    # the same ridge peer, its agreement left out (it learns another cost).
    rows += [(f"imitate, trees, {threads} thread(s)",
              imitate_round(work, args.rounds, threads, "tree"), float("nan"))
             for threads in sorted({1, args.threads})]
    times, _ = peer(maps, paths, sorted(paths), [], 1 + args.rounds, args.threads)
    peer_round = min(times[1:]) if len(times) > 1 else times[0]
    _, peer_agreement = peer(maps, paths, training, holdout, 1 + args.rounds, args.threads)
    rows.append((f"NumPy/SciPy, {args.threads} process(es)", peer_round, peer_agreement))
    print("| run | seconds per round (all examples) | held-out cells within 2 cells "
          "(a quarter held out) | peer / this |")
    print("|---|---|---|---|")
    for name, seconds, agreement in rows:
        print(f"| {name} | {seconds:.3f} | {agreement:.3f} | {peer_round / seconds:.1f}× |")


if __name__ == "__main__":
    main()
