"""The Python package against the command line, in one workspace: the same stages give
the same artifacts, the same plans and the same errors; arrays hold what the files
hold; DAgger rounds append from pandas, polars and pyarrow tables; a policy acts as
its ONNX export does. Prints one JSON line per check; any failure raises.

Usage: package_api.py WORKSPACE IMITATE_BINARY (the workspace holds the quickstart,
already run by the binary).
"""

import json
import os
import subprocess
import sys

import numpy as np
import pandas as pd
import polars as pl
import pyarrow as pa
import pyarrow.parquet as pq

import imitate

workspace, binary = sys.argv[1], sys.argv[2]
os.chdir(workspace)


def cli(*args, ok=True):
    run = subprocess.run([binary, *args], capture_output=True, text=True)
    if ok and run.returncode != 0:
        raise AssertionError(f"imitate {' '.join(args)}: {run.stderr}")
    return run


def report(check, **values):
    print(json.dumps({"check": check, **values}))


# A stage run from Python writes the artifact the command writes.
cli("learch", "--dataset", "out/quickstart/dataset", "--features", "out/quickstart/features",
    "--out", "by-cli", "--rounds", "5")
ran = imitate.run_stage("learch", dataset="out/quickstart/dataset",
                        features="out/quickstart/features", out="by-python", rounds=5)
with open("by-cli/manifest.json") as f:
    by_cli = json.load(f)["digest"]
assert ran["digest"] == by_cli, (ran, by_cli)
assert "learch" in imitate.stage_kinds()
report("run_stage", digest=ran["digest"])

# The pipeline run from Python finds the command's run up to date.
outcomes = imitate.run_pipeline("pipelines/quickstart.yaml")
assert [o["ran"] for o in outcomes] == [False] * len(outcomes), outcomes
report("run_pipeline", stages=len(outcomes))

# A costmap reads as its table holds it (row 0 south, float32).
costmap = imitate.read_costmap("out/quickstart/costmap", "terrain-000")
table = pq.read_table("out/quickstart/costmap/costmaps/terrain-000.parquet").to_pandas()
assert costmap.costs.dtype == np.float32
assert costmap.costs.shape == (costmap.georef["height"], costmap.georef["width"])
cost_column = [c for c in table.columns if c.startswith("cost")][0]
assert np.array_equal(costmap.costs.ravel(), table[cost_column].to_numpy(np.float32))
report("read_costmap", shape=list(costmap.costs.shape))

# Plans are the command's: the same cells, the same cost.
route = imitate.plan(costmap.costs, (2, 3), (60, 55))
planned = json.loads(cli("plan", "out/quickstart/costmap", "--map", "terrain-000", "--cells",
                         "--start", "2,3", "--goal", "60,55").stdout)
assert route.cells.tolist() == planned["cells"], (route.cells.tolist()[:5], planned["cells"][:5])
assert abs(route.cost - planned["cost"]) <= 1e-9 * planned["cost"]
blocked = costmap.costs.copy()
blocked[:, 30] = np.inf
assert imitate.plan(blocked, (2, 3), (60, 55)) is None
report("plan", cells=len(route.cells), cost=route.cost)

# Features and paths.
features = imitate.read_features("out/quickstart/features/features/terrain-000.parquet")
assert features.values.shape == (len(features.names), 64, 64)
names, values = imitate.compute_features(
    "testdata/world/maps/terrain-000.parquet", features.spec)
assert names == features.names and np.array_equal(values, features.values)
paths = imitate.read_paths("out/quickstart/costmap/paths.parquet")
assert all(cells.shape[1] == 2 for _, _, cells in paths) and len(paths) > 10
report("features", features=len(names), paths=len(paths))

# Errors carry the command's message, as the matching exception.
try:
    imitate.read_costmap("no-such-costmap")
    raise AssertionError("no error")
except imitate.InputError as e:
    message = str(e)
refused = cli("plan", "no-such-costmap", "--cells", "--start", "0,0", "--goal", "1,1", ok=False)
assert refused.returncode == 2 and message in refused.stderr, (message, refused.stderr)
for bad in [dict(connectivity=6), dict()]:
    try:
        if bad:
            imitate.plan(costmap.costs, (0, 0), (1, 1), **bad)
        else:
            imitate.plan(costmap.costs, (0, 0), (99, 99))
        raise AssertionError("no error")
    except imitate.ImitateError as e:
        assert isinstance(e, (imitate.UsageError, imitate.InputError)), e
try:
    imitate.run_stage("learch", dataset="out/quickstart/dataset", out="x", roundz=3)
    raise AssertionError("no error")
except imitate.ImitateError as e:
    assert "roundz" in str(e), e
report("errors", message=message)

# DAgger rounds from tables, in memory: pandas, polars, pyarrow.
cli("dagger", "init", "ds", "--env", "log", "--observations", "x,y", "--actions", "u")
rng = np.random.default_rng(0)


def frame(episodes, offset):
    x, y = rng.normal(size=(2, 40 * episodes))
    return pd.DataFrame({"episode": np.repeat(np.arange(episodes) + offset, 40),
                         "x": x, "y": y, "u": 0.5 * x - 0.25 * y})


first = frame(3, 0)
assert imitate.append_round("ds", first, observations=["x", "y"], action="u",
                            episode="episode") == (0, True)
assert imitate.append_round("ds", first, observations=["x", "y"], action="u",
                            episode="episode") == (0, False)
assert imitate.append_round("ds", pl.from_pandas(frame(2, 3)), observations=["x", "y"],
                            action="u", episode="episode") == (1, True)
assert imitate.append_round("ds", pa.Table.from_pandas(frame(2, 5)), observations=["x", "y"],
                            action="u", episode="episode") == (2, True)
status = json.loads(cli("dagger", "status", "ds", "--json").stdout)
assert [r["steps"] for r in status] == [120, 80, 80], status
try:
    imitate.append_round("ds", frame(1, 9), observations=["x", "nope"], action="u",
                         episode="episode")
    raise AssertionError("no error")
except imitate.InputError as e:
    assert "nope" in str(e), e
report("append_round", rounds=len(status))

# A policy acts as its ONNX export does.
cli("dagger", "train", "ds", "--out", "policy", "--learner", "ridge")
cli("export", "policy", "--out", "onnx", "--format", "onnx")
policy = imitate.Policy("policy")
assert policy.observation_names == ["x", "y"]
observations = rng.normal(size=(50, 2))
actions = policy.act(observations)
import onnxruntime as ort  # noqa: E402

session = ort.InferenceSession("onnx/policy.onnx")
expected = session.run(None, {"observation": observations.astype(np.float32)})[0]
assert actions.shape == (50, 1)
assert np.allclose(actions, expected, atol=1e-5), np.abs(actions - expected).max()
assert np.allclose(actions[:, 0], 0.5 * observations[:, 0] - 0.25 * observations[:, 1], atol=0.01)
try:
    policy.act(np.zeros((2, 3)))
    raise AssertionError("no error")
except imitate.InputError as e:
    assert "x, y" in str(e), e
report("policy", digest=policy.digest)
