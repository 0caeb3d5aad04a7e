"""Ingest on Ray against the command line, on a local Ray cluster of two nodes
(loopback only): the quickstart's four MCAP logs decoded one task each give the dataset
`imitate ingest` writes, byte for byte, also when the worker decoding a log dies on its
first attempt (Ray retries the task). Prints one JSON line per run; any failure raises.

Usage: ray_ingest.py WORKSPACE IMITATE_BINARY REPOSITORY
"""

import json
import os
import subprocess
import sys

import ray
from ray.cluster_utils import Cluster

import imitate
import imitate.ray

results = os.fdopen(os.dup(1), "w", buffering=1)
os.dup2(2, 1)

workspace, binary, repository = sys.argv[1], sys.argv[2], sys.argv[3]
os.chdir(workspace)
logs = [os.path.join(repository, f"testdata/world/logs/terrain-00{i}.mcap") for i in range(4)]
params = dict(logs=logs, goal_topic="/goal", split="goal")

args = [binary, "ingest", "--goal-topic", "/goal", "--split", "goal", "--out", "single"]
for log in logs:
    args += ["--log", log]
run = subprocess.run(args, capture_output=True, text=True)
assert run.returncode == 0, run.stderr
with open(os.path.join("single", "manifest.json")) as f:
    expected = json.load(f)["digest"]
results.write(json.dumps({"run": "command line", "digest": expected}) + "\n")

# The first attempt at decoding the second log kills its worker process.
marker = os.path.abspath("killed-once")


def dying_once(params_text, index):
    if index == 1 and not os.path.exists(marker):
        open(marker, "w").close()
        os._exit(1)
    return imitate.ray._ingest_log(params_text, index)


cluster = Cluster(initialize_head=True, head_node_args={"num_cpus": 2, "include_dashboard": False})
cluster.add_node(num_cpus=2)
ray.init(address=cluster.address, log_to_driver=False)
try:
    report = imitate.ray.ingest(out=os.path.abspath("ray"), **params)
    assert report["digest"] == expected, (report, expected)
    results.write(json.dumps({"run": "ray", "digest": report["digest"]}) + "\n")

    original = imitate.ray._ingest_log
    imitate.ray._ingest_log = dying_once
    try:
        report = imitate.ray.ingest(out=os.path.abspath("ray-killed"), **params)
    finally:
        imitate.ray._ingest_log = original
    assert os.path.exists(marker), "the worker was not killed"
    assert report["digest"] == expected, (report, expected)
    results.write(json.dumps({"run": "ray, a worker killed", "digest": report["digest"]}) + "\n")
finally:
    ray.shutdown()
    cluster.shutdown()
