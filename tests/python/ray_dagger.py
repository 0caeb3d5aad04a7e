"""DAgger rollouts as Ray tasks in gymnasium's Pendulum-v1 on a local cluster of two
nodes: the rounds appended from the cluster (the teacher's, then a policy's mixed with
the teacher at beta 0.5) are the rounds the same episodes make here, byte for byte.
Prints one JSON line per round; any failure raises.

Usage: ray_dagger.py WORKSPACE IMITATE_BINARY
"""

import json
import math
import os
import subprocess
import sys

import gymnasium as gym
import numpy as np
import ray
from ray.cluster_utils import Cluster

import imitate.ray

# Ray's own messages go to stdout: the results get the real stdout to themselves.
results = os.fdopen(os.dup(1), "w", buffering=1)
os.dup2(2, 1)

workspace, binary = sys.argv[1], sys.argv[2]
os.chdir(workspace)


def cli(*args):
    run = subprocess.run([binary, *args], capture_output=True, text=True)
    assert run.returncode == 0, (args, run.stderr)
    return run.stdout


def teacher(observation):
    """Energy pumping far from the top, state feedback near it."""
    cos, sin, omega = (float(v) for v in observation)
    theta = math.atan2(sin, cos)
    if cos > 0.9 and abs(omega) < 3.0:
        u = -(13.3 * theta + 3.3 * omega)
    else:
        u = 0.6 * -(0.5 * omega * omega + 15.0 * (cos - 1.0)) * omega
        if abs(omega) < 0.05:
            u = 1.0
    return float(np.clip(u, -2.0, 2.0))


def make_env():
    return gym.make("Pendulum-v1")


for ds in ("ds-ray", "ds-local"):
    cli("dagger", "init", ds, "--env", "log", "--observations", "cos,sin,omega",
        "--actions", "torque")

cluster = Cluster(initialize_head=True, head_node_args={"num_cpus": 2, "include_dashboard": False})
cluster.add_node(num_cpus=2)
ray.init(address=cluster.address, log_to_driver=False)
try:
    rounds = [dict(policy=None, seeds=[1, 2, 3, 4], beta=0.0),
              dict(policy="policy", seeds=[5, 6, 7, 8], beta=0.5)]
    for number, spec in enumerate(rounds):
        made = {}
        for ds, local in (("ds-ray", False), ("ds-local", True)):
            made[ds] = imitate.ray.dagger_round(ds, make_env, teacher, spec["policy"],
                                                seeds=spec["seeds"], max_steps=60,
                                                beta=spec["beta"], local=local)
        assert made["ds-ray"] == made["ds-local"], made
        assert made["ds-ray"][0] == (number, True), made
        part = f"data/round={number:03}/part-000.parquet"
        with open(os.path.join("ds-ray", part), "rb") as a, \
                open(os.path.join("ds-local", part), "rb") as b:
            assert a.read() == b.read(), part
        status = json.loads(cli("dagger", "status", "ds-ray", "--json"))
        assert status == json.loads(cli("dagger", "status", "ds-local", "--json"))
        assert status[number]["steps"] == 4 * 60, status
        results.write(json.dumps({"round": number, "steps": status[number]["steps"],
                                  "returns": made["ds-ray"][1]}) + "\n")
        if number == 0:
            cli("dagger", "train", "ds-ray", "--out", "policy", "--learner", "tree")
finally:
    ray.shutdown()
    cluster.shutdown()
