"""`python -m imitate.ray run` on a local Ray cluster of two nodes (loopback only): the
quickstart pipeline run in WORKSPACE, each stale stage a Ray task, then run again
(every stage up to date), then forced with the learch stage's rounds planned on two
actors. Prints one JSON line per run with each stage's (name, digest) and the stages
that ran; any failure raises.

Usage: ray_pipeline.py WORKSPACE PIPELINE
"""

import json
import os
import subprocess
import sys

import ray
from ray.cluster_utils import Cluster

results = os.fdopen(os.dup(1), "w", buffering=1)
os.dup2(2, 1)

workspace, pipeline = sys.argv[1], sys.argv[2]

cluster = Cluster(initialize_head=True, head_node_args={"num_cpus": 2, "include_dashboard": False})
cluster.add_node(num_cpus=2)
try:
    runs = {"first": [], "again": [], "forced, learch on actors": ["--force",
                                                                  "--learch-actors", "2"]}
    for attempt, extra in runs.items():
        run = subprocess.run(
            [sys.executable, "-m", "imitate.ray", "run", pipeline, "--address", cluster.address,
             "--cpus-per-stage", "1", *extra],
            cwd=workspace, capture_output=True, text=True, timeout=900)
        assert run.returncode == 0, run.stderr
        stages = []
        for line in run.stdout.splitlines():
            name, out, digest = line.split("\t")
            stages.append({"name": name, "digest": digest})
        ran = [l.split(":")[0] for l in run.stderr.splitlines()
               if ": " in l and not l.endswith(": up to date")
               and l.split(":")[0] in {s["name"] for s in stages}]
        results.write(json.dumps({"run": attempt, "stages": stages, "ran": ran}) + "\n")
finally:
    cluster.shutdown()
