#!/usr/bin/env python3
"""Policies from a LeRobot dataset: per-dimension held-out error of every imitate learner
against the mean-action baseline, training time per 100 k frames, and the exported ONNX
policy's size and onnxruntime latency per batch.

The dataset follows LeRobot's v3.0 layout (meta/info.json with feature names and
shapes, data/chunk-000/file-NNN.parquet with `observation.state` and `action` as
fixed-size lists, episode and frame indices, a video feature that is not in the
tables): a 6-joint arm teleoperated under position control, as SO-100 / Koch datasets
are recorded. Each episode moves the joints along smooth random trajectories; the
recorded action is the commanded position, a look-ahead of the state (the arm lags its
command by a few frames) with operator noise, so the action is a nonlinear function of
what the state holds (positions, not velocities), and a mean-action policy is far off.

Run from the repository root after `cargo build --release`:

    PYTHONPATH=target/python-deps python3 benches/lerobot_policies.py [--frames 100000]
"""

import argparse
import json
import os
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
import onnxruntime
import pyarrow as pa
import pyarrow.parquet as pq

IMITATE = os.path.join(os.path.dirname(__file__), "..", "target", "release", "imitate")
JOINTS = ["shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll", "gripper"]
FPS = 30
LAG = 4  # frames between a command and the arm reaching it


def episode(rng, frames):
    """States (degrees) and commanded positions of one episode."""
    t = np.arange(frames + LAG)[:, None] / FPS
    speeds = rng.uniform(0.2, 1.5, size=(3, len(JOINTS)))
    phases = rng.uniform(0, 2 * np.pi, size=(3, len(JOINTS)))
    amplitudes = rng.uniform(10, 60, size=(3, len(JOINTS))) / np.arange(1, 4)[:, None]
    path = sum(a * np.sin(s * t * (k + 1) + p)
               for k, (a, s, p) in enumerate(zip(amplitudes, speeds, phases)))
    path[:, -1] = 50 + 45 * np.tanh(path[:, -1] / 20)  # the gripper saturates
    states = path[:frames] + rng.normal(0, 0.3, size=(frames, len(JOINTS)))
    commands = path[LAG:] + rng.normal(0, 1.0, size=(frames, len(JOINTS)))
    return states.astype(np.float32), commands.astype(np.float32)


def write_dataset(folder, frames, episode_frames, rng):
    folder = Path(folder)
    (folder / "meta").mkdir(parents=True)
    (folder / "data/chunk-000").mkdir(parents=True)
    vector = pa.list_(pa.float32(), len(JOINTS))
    count = frames // episode_frames
    per_file = 50
    index = 0
    for first in range(0, count, per_file):
        columns = {k: [] for k in ("state", "action", "episode", "frame", "index", "time")}
        for e in range(first, min(first + per_file, count)):
            states, actions = episode(rng, episode_frames)
            columns["state"].extend(states.tolist())
            columns["action"].extend(actions.tolist())
            columns["episode"].extend([e] * episode_frames)
            columns["frame"].extend(range(episode_frames))
            columns["time"].extend((np.arange(episode_frames) / FPS).tolist())
            columns["index"].extend(range(index, index + episode_frames))
            index += episode_frames
        table = pa.table({
            "observation.state": pa.array(columns["state"], vector),
            "action": pa.array(columns["action"], vector),
            "timestamp": pa.array(columns["time"], pa.float32()),
            "frame_index": pa.array(columns["frame"], pa.int64()),
            "episode_index": pa.array(columns["episode"], pa.int64()),
            "index": pa.array(columns["index"], pa.int64()),
            "task_index": pa.array([0] * len(columns["frame"]), pa.int64()),
        })
        pq.write_table(table, folder / f"data/chunk-000/file-{first // per_file:03}.parquet")
    info = {
        "codebase_version": "v3.0",
        "robot_type": "so100",
        "fps": FPS,
        "total_episodes": count,
        "total_frames": index,
        "data_path": "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet",
        "features": {
            "observation.state": {"dtype": "float32", "shape": [len(JOINTS)], "names": JOINTS},
            "action": {"dtype": "float32", "shape": [len(JOINTS)], "names": JOINTS},
            "observation.images.front": {"dtype": "video", "shape": [480, 640, 3],
                                         "names": ["height", "width", "channels"]},
            "timestamp": {"dtype": "float32", "shape": [1], "names": None},
            "frame_index": {"dtype": "int64", "shape": [1], "names": None},
            "episode_index": {"dtype": "int64", "shape": [1], "names": None},
            "index": {"dtype": "int64", "shape": [1], "names": None},
            "task_index": {"dtype": "int64", "shape": [1], "names": None},
        },
    }
    (folder / "meta/info.json").write_text(json.dumps(info, indent=2))
    return index


def imitate(*args):
    done = subprocess.run([IMITATE, *args], capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"imitate {' '.join(args)}: {done.stderr}")
    return done.stdout


def latency(model, rows, batch, repeat):
    session = onnxruntime.InferenceSession(model, providers=["CPUExecutionProvider"])
    session.set_providers(["CPUExecutionProvider"])
    x = rows[:batch]
    session.run(["action"], {"observation": x})
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        session.run(["action"], {"observation": x})
        best = min(best, time.perf_counter() - start)
    return best


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--frames", type=int, default=100_000)
    parser.add_argument("--episode-frames", type=int, default=500)
    parser.add_argument("--learners", default="ridge,tree,mlp")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = os.path.join(tmp, "so100_teleop")
        frames = write_dataset(folder, args.frames, args.episode_frames, rng)
        dataset = os.path.join(tmp, "ds")
        imitate("dagger", "init", dataset, "--lerobot", folder)
        imitate("dagger", "add", dataset, "--lerobot", folder)
        probe = np.asarray(pq.read_table(os.path.join(folder, "data/chunk-000/file-000.parquet"),
                                         columns=["observation.state"])
                           .column(0).to_pylist()[:1024], dtype=np.float32)
        for learner in args.learners.split(","):
            policy = os.path.join(tmp, f"policy-{learner}")
            extra = {"tree": ["--depth", "8"], "mlp": ["--hidden", "64,64", "--epochs", "20"]}
            start = time.perf_counter()
            imitate("dagger", "train", dataset, "--out", policy, "--learner", learner,
                    "--validation", "0.2", *extra.get(learner, []))
            seconds = time.perf_counter() - start
            metrics = json.load(open(os.path.join(policy, "metrics.json")))
            exported = policy + "-onnx"
            imitate("export", policy, "--out", exported, "--format", "onnx")
            model = os.path.join(exported, "policy.onnx")
            results.append({
                "learner": learner,
                "train_seconds": seconds,
                "seconds_per_100k_frames": seconds * 100_000 / frames,
                "validation_rmse": metrics["validation_rmse_per_action"],
                "mean_action_rmse": metrics["validation_mean_action_rmse_per_action"],
                "onnx_bytes": os.path.getsize(model),
                "latency_batch_1_ms": 1e3 * latency(model, probe, 1, 200),
                "latency_batch_1024_ms": 1e3 * latency(model, probe, 1024, 50),
            })
    if args.json:
        print(json.dumps({"frames": frames, "joints": JOINTS, "results": results}))
        return
    print(f"{frames} frames, {len(JOINTS)} joints; held-out RMSE per joint (degrees), "
          "mean-action baseline first")
    print("learner   " + "  ".join(f"{j[:12]:>12}" for j in JOINTS))
    print("mean      " + "  ".join(f"{v:>12.2f}" for v in results[0]["mean_action_rmse"]))
    for r in results:
        print(f"{r['learner']:<9} " + "  ".join(f"{v:>12.2f}" for v in r["validation_rmse"]))
    for r in results:
        print(f"{r['learner']}: train {r['train_seconds']:.2f} s "
              f"({r['seconds_per_100k_frames']:.2f} s per 100k frames); ONNX "
              f"{r['onnx_bytes'] / 1024:.1f} KiB, onnxruntime {r['latency_batch_1_ms']:.3f} ms "
              f"per batch of 1, {r['latency_batch_1024_ms']:.3f} ms per batch of 1024")


if __name__ == "__main__":
    main()
