"""imitate.ray against the single-machine run, on a local Ray cluster of three nodes
(loopback only): the LEARCH artifact has the single-machine digest with 1, 3 and 5
actors, and when an actor is killed mid-run (Ray restarts it and retries its round).
Prints one JSON line per run; any failure raises.

Usage: ray_learch.py WORKSPACE IMITATE_BINARY DATASET FEATURES (a dataset and a
features artifact of the quickstart, made by the binary, relative to the workspace).
"""

import json
import os
import subprocess
import sys
import time

import ray
from ray.cluster_utils import Cluster

import imitate.ray

# Ray's own messages (a retried task, a restarted actor) go to stdout: this script's
# results get the real stdout to themselves and everything else goes to stderr.
results = os.fdopen(os.dup(1), "w", buffering=1)
os.dup2(2, 1)


def emit(record):
    results.write(json.dumps(record) + "\n")


workspace, binary = sys.argv[1], sys.argv[2]
os.chdir(workspace)
dataset, features = os.path.abspath(sys.argv[3]), os.path.abspath(sys.argv[4])
rounds = 6

single = os.path.abspath("single")
run = subprocess.run(
    [binary, "learch", "--dataset", dataset, "--features", features, "--out", single,
     "--rounds", str(rounds)],
    capture_output=True, text=True)
assert run.returncode == 0, run.stderr
with open(os.path.join(single, "manifest.json")) as f:
    expected = json.load(f)["digest"]
emit({"run": "single machine", "digest": expected})

started = time.time()
cluster = Cluster(initialize_head=True, head_node_args={"num_cpus": 2})
for _ in range(2):
    cluster.add_node(num_cpus=2)
ray.init(address=cluster.address, log_to_driver=False)
try:
    assert len([n for n in ray.nodes() if n["Alive"]]) == 3
    for actors in (1, 3, 5):
        began = time.time()
        report = imitate.ray.learch(actors=actors, dataset=dataset, features=features,
                                    out=os.path.abspath(f"ray-{actors}"), rounds=rounds)
        assert report["digest"] == expected, (actors, report, expected)
        emit({"run": f"{actors} actors", "digest": report["digest"],
              "seconds": round(time.time() - began, 2)})

    killed = []

    def kill_one(round_, workers):
        # Mid-run: the second actor dies before round 3's plans are sent; Ray restarts
        # it (its inputs load again) and retries the call.
        if round_ == 2:
            ray.kill(workers[1], no_restart=False)
            killed.append(round_)

    report = imitate.ray.learch(actors=3, on_round=kill_one, dataset=dataset,
                                features=features, out=os.path.abspath("ray-killed"),
                                rounds=rounds)
    assert killed == [2], killed
    assert report["digest"] == expected, (report, expected)
    emit({"run": "3 actors, one killed", "digest": report["digest"]})

    # The actors plan with the corridor the driver's round takes (what `corridor: auto`
    # changes between its trainings), not only their parameters'.
    corridor = os.path.abspath("single-corridor")
    run = subprocess.run(
        [binary, "learch", "--dataset", dataset, "--features", features, "--out",
         corridor, "--rounds", str(rounds), "--corridor", "1"],
        capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    with open(os.path.join(corridor, "manifest.json")) as f:
        expected = json.load(f)["digest"]
    emit({"run": "single machine, corridor 1", "digest": expected})
    report = imitate.ray.learch(actors=3, dataset=dataset, features=features,
                                out=os.path.abspath("ray-corridor"), rounds=rounds,
                                corridor=1)
    assert report["digest"] == expected, (report, expected)
    emit({"run": "3 actors, corridor 1", "digest": report["digest"]})
finally:
    ray.shutdown()
    cluster.shutdown()
emit({"run": "cluster", "seconds": round(time.time() - started, 2)})
