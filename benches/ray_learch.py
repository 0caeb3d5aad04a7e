"""LEARCH rounds on Ray against the in-process trainer, in one run, on one world.

Writes a synthetic world (`imitate testdata world`), ingests it and computes its
features, then times `imitate learch` (in-process, at 1 thread and at all threads) and
`imitate.ray.learch` with each number of actors on a local Ray cluster of one node
with as many CPUs as the machine has (or --cpus). Every run must give the same
artifact digest. Reports the time per round, the overhead of Ray per round over the
in-process trainer at the same parallelism, and the peak resident memory of each actor
and of the driver (which holds every map's features: it fits and evaluates).
`--in-process most` runs it at all threads only, `none` not at all (for large worlds).

    scripts/python-deps.sh && scripts/python-package.sh && cargo build --release
    PYTHONPATH=target/python-package:target/python-deps python3 benches/ray_learch.py \\
        --maps 8 --size 256 --demonstrations-per-map 16 --rounds 5 --actors 1 2
"""

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time

import ray

import imitate.ray

parser = argparse.ArgumentParser()
parser.add_argument("--binary", default="target/release/imitate")
parser.add_argument("--maps", type=int, default=8)
parser.add_argument("--size", type=int, default=256)
parser.add_argument("--demonstrations-per-map", type=int, default=16)
parser.add_argument("--rounds", type=int, default=5)
parser.add_argument("--actors", type=int, nargs="+", default=[1, 2])
parser.add_argument("--cpus", type=int, default=os.cpu_count())
parser.add_argument("--in-process", choices=["all", "most", "none"], default="all",
                    help="in-process runs at 1 and all threads, at all threads only, or none")
parser.add_argument("--work", default=None, help="folder for the world (default: a temporary one)")
args = parser.parse_args()
binary = os.path.abspath(args.binary)


def imitate_cli(*argv, threads=None):
    """Runs the binary; returns its peak resident memory in bytes."""
    env = dict(os.environ)
    if threads:
        env["RAYON_NUM_THREADS"] = str(threads)
    child = subprocess.Popen([binary, *argv], stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE, text=True, env=env)
    stderr = child.stderr.read()
    _, status, usage = os.wait4(child.pid, 0)
    child.returncode = os.waitstatus_to_exitcode(status)
    if child.returncode != 0:
        sys.exit(f"imitate {' '.join(argv)}: {stderr}")
    return usage.ru_maxrss * 1024


def digest(folder):
    with open(os.path.join(folder, "manifest.json")) as f:
        return json.load(f)["digest"]


work = args.work or tempfile.mkdtemp(prefix="imitate-ray-bench-")
os.makedirs(work, exist_ok=True)
world = os.path.join(work, "world")
made = time.perf_counter()
imitate_cli("testdata", "world", "--out", world, "--maps", str(args.maps), "--width",
            str(args.size), "--height", str(args.size), "--demonstrations-per-map",
            str(args.demonstrations_per_map))
maps = sorted(os.listdir(os.path.join(world, "maps")))
ingest = ["ingest", "--demonstrations", os.path.join(world, "demonstrations.parquet")]
for m in maps:
    ingest += ["--map", os.path.join(world, "maps", m)]
dataset, features = os.path.join(work, "ds"), os.path.join(work, "fs")
imitate_cli(*ingest, "--out", dataset)
imitate_cli("features", "--dataset", dataset, "--out", features)
print(f"world, dataset and features made in {time.perf_counter() - made:.0f} s")
params = dict(dataset=dataset, features=features, rounds=args.rounds)
cells = args.maps * args.size * args.size
print(f"world: {args.maps} maps of {args.size}² ({cells} cells), "
      f"{args.maps * args.demonstrations_per_map} demonstrations, {args.rounds} rounds; "
      f"{os.cpu_count()} cores")

rows = []
expected = None
in_process_threads = {"all": sorted({1, args.cpus}), "most": [args.cpus], "none": []}
for threads in in_process_threads[args.in_process]:
    out = os.path.join(work, f"in-process-{threads}")
    began = time.perf_counter()
    peak = imitate_cli("learch", "--dataset", dataset, "--features", features, "--out", out,
                       "--rounds", str(args.rounds), threads=threads)
    seconds = time.perf_counter() - began
    expected = expected or digest(out)
    assert digest(out) == expected
    rows.append((f"in-process, {threads} thread(s)", threads, seconds))
    print(f"in-process, {threads} thread(s): {seconds:.1f} s; peak memory {peak / 2**20:.0f} MiB")

ray.init(num_cpus=args.cpus, include_dashboard=False, log_to_driver=False)
for actors in args.actors:
    out = os.path.join(work, f"ray-{actors}")
    began = time.perf_counter()
    report = imitate.ray.learch(actors=actors, out=out, **params)
    seconds = time.perf_counter() - began
    expected = expected or report["digest"]
    assert report["digest"] == expected, (report, expected)
    rows.append((f"Ray, {actors} actor(s)", actors, seconds))
    peaks = ", ".join(f"{p / 2**20:.0f}" for p in report["actors_peak_memory"])
    print(f"{actors} actor(s): {seconds:.1f} s; actors' peak memory (MiB): {peaks}")
ray.shutdown()

in_process = {threads: s for name, threads, s in rows if name.startswith("in-process")}
print(f"| run | total s | s per round | Ray's overhead per round |")
print(f"|---|---|---|---|")
for name, parallel, seconds in rows:
    overhead = ""
    if name.startswith("Ray") and parallel in in_process:
        overhead = f"{(seconds - in_process[parallel]) / args.rounds:+.3f} s"
    print(f"| {name} | {seconds:.2f} | {seconds / args.rounds:.3f} | {overhead} |")
print(f"every run: {expected}")
driver = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**10
print(f"driver's peak memory: {driver:.0f} MiB")

