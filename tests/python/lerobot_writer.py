"""Writes LeRobot datasets the way LeRobot (through Hugging Face `datasets`) lays them
out, with pyarrow: a humanoid-like robot whose `observation.state` and `action` hold 26
joints each, the action a known linear function of the state (degrees, far outside
[-1, 1]), plus a camera feature stored as video (not in the tables).

- `v21/`: codebase v2.1, one file per episode (data/chunk-000/episode_000000.parquet),
  list<float> columns, meta/info.json, episodes.jsonl, tasks.jsonl, episodes_stats.jsonl.
- `v30/`: codebase v3.0, several episodes per file (data/chunk-000/file-000.parquet),
  fixed_size_list<float>[26] columns, names given as {"motors": [...]} (as v2.0 did).

Prints one JSON line per folder: {"folder", "version", "frames", "episodes", "names",
"probes": [{"state", "action"}]}, the probes being states between the recorded ones
(midpoints of two frames) and the rule's actions for them.

usage: lerobot_writer.py OUT_DIR
"""

import json
import sys
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

JOINTS = 26
FPS = 30
NAMES = [f"{side}_{part}" for side in ("left", "right") for part in (
    "hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll",
    "shoulder_pitch", "shoulder_roll", "shoulder_yaw", "elbow", "wrist_roll", "wrist_pitch",
    "gripper",
)]
assert len(NAMES) == JOINTS

rng = np.random.default_rng(7)
WEIGHTS = rng.normal(0.0, 0.3, size=(JOINTS, JOINTS))
OFFSETS = rng.uniform(-60.0, 60.0, size=JOINTS)


def rule(states):
    return states @ WEIGHTS.T + OFFSETS


def episode_states(episode, frames):
    t = np.arange(frames)[:, None] / FPS
    phase = rng.uniform(0, 2 * np.pi, size=JOINTS)
    speed = rng.uniform(0.5, 2.0, size=JOINTS)
    # Smooth motion, an offset per episode, and per-frame jitter (teleoperation).
    smooth = 30.0 * np.sin(speed * t + phase) + rng.normal(0, 5.0, size=JOINTS) + episode
    return smooth + rng.normal(0.0, 8.0, size=(frames, JOINTS))


def features(names_as):
    names = {"motors": NAMES} if names_as == "motors" else NAMES
    return {
        "observation.state": {"dtype": "float32", "shape": [JOINTS], "names": names},
        "action": {"dtype": "float32", "shape": [JOINTS], "names": names},
        "observation.images.head": {
            "dtype": "video",
            "shape": [480, 640, 3],
            "names": ["height", "width", "channels"],
        },
        "timestamp": {"dtype": "float32", "shape": [1], "names": None},
        "frame_index": {"dtype": "int64", "shape": [1], "names": None},
        "episode_index": {"dtype": "int64", "shape": [1], "names": None},
        "index": {"dtype": "int64", "shape": [1], "names": None},
        "task_index": {"dtype": "int64", "shape": [1], "names": None},
    }


def hf_features(fixed):
    """The `huggingface` schema metadata `datasets` writes."""
    sequence = {"feature": {"dtype": "float32", "_type": "Value"}, "_type": "Sequence"}
    if fixed:
        sequence["length"] = JOINTS
    value = lambda dtype: {"dtype": dtype, "_type": "Value"}  # noqa: E731
    return {
        "info": {
            "features": {
                "observation.state": sequence,
                "action": sequence,
                "timestamp": value("float32"),
                "frame_index": value("int64"),
                "episode_index": value("int64"),
                "index": value("int64"),
                "task_index": value("int64"),
            }
        }
    }


def table(episodes, first_index, fixed):
    columns = {k: [] for k in ("state", "action", "timestamp", "frame", "episode", "index")}
    index = first_index
    for episode, states in episodes:
        actions = rule(states)
        for frame, (state, action) in enumerate(zip(states, actions)):
            columns["state"].append(state.astype(np.float32))
            columns["action"].append(action.astype(np.float32))
            columns["timestamp"].append(frame / FPS)
            columns["frame"].append(frame)
            columns["episode"].append(episode)
            columns["index"].append(index)
            index += 1
    vector = pa.list_(pa.float32(), JOINTS) if fixed else pa.list_(pa.float32())
    arrays = [
        pa.array(columns["state"], type=vector),
        pa.array(columns["action"], type=vector),
        pa.array(columns["timestamp"], type=pa.float32()),
        pa.array(columns["frame"], type=pa.int64()),
        pa.array(columns["episode"], type=pa.int64()),
        pa.array(columns["index"], type=pa.int64()),
        pa.array([0] * len(columns["frame"]), type=pa.int64()),
    ]
    names = ["observation.state", "action", "timestamp", "frame_index", "episode_index",
             "index", "task_index"]
    schema = pa.schema(
        [pa.field(n, a.type) for n, a in zip(names, arrays)],
        metadata={b"huggingface": json.dumps(hf_features(fixed)).encode()},
    )
    return pa.Table.from_arrays(arrays, schema=schema)


def write_meta(folder, version, episodes, names_as, data_path):
    meta = folder / "meta"
    meta.mkdir(parents=True, exist_ok=True)
    frames = sum(len(states) for _, states in episodes)
    info = {
        "codebase_version": version,
        "robot_type": "humanoid",
        "total_episodes": len(episodes),
        "total_frames": frames,
        "total_tasks": 1,
        "chunks_size": 1000,
        "fps": FPS,
        "splits": {"train": f"0:{len(episodes)}"},
        "data_path": data_path,
        "video_path": "videos/chunk-{episode_chunk:03d}/{video_key}/episode_{episode_index:06d}.mp4",
        "features": features(names_as),
    }
    (meta / "info.json").write_text(json.dumps(info, indent=4))
    if version.startswith("v2"):
        with open(meta / "episodes.jsonl", "w") as f:
            for episode, states in episodes:
                f.write(json.dumps({"episode_index": episode, "tasks": ["walk"],
                                    "length": len(states)}) + "\n")
        (meta / "tasks.jsonl").write_text(json.dumps({"task_index": 0, "task": "walk"}) + "\n")
        with open(meta / "episodes_stats.jsonl", "w") as f:
            for episode, states in episodes:
                f.write(json.dumps({"episode_index": episode, "stats": {
                    "observation.state": {"mean": states.mean(0).tolist()}}}) + "\n")
    return frames


def main():
    out = Path(sys.argv[1])
    def probes(episodes):
        states = np.concatenate([s for _, s in episodes])
        pick = rng.integers(0, len(states), size=(4, 2))
        mids = 0.5 * (states[pick[:, 0]] + states[pick[:, 1]])
        return [{"state": s.tolist(), "action": a.tolist()} for s, a in zip(mids, rule(mids))]

    v21 = out / "v21"
    episodes = [(e, episode_states(e, 90 + 10 * e)) for e in range(3)]
    probe_rows = probes(episodes)
    frames = write_meta(v21, "v2.1", episodes, "list",
                        "data/chunk-{episode_chunk:03d}/episode_{episode_index:06d}.parquet")
    index = 0
    for episode, states in episodes:
        path = v21 / "data" / "chunk-000" / f"episode_{episode:06d}.parquet"
        path.parent.mkdir(parents=True, exist_ok=True)
        pq.write_table(table([(episode, states)], index, fixed=False), path)
        index += len(states)
    print(json.dumps({"folder": str(v21), "version": "v2.1", "frames": frames,
                      "episodes": len(episodes), "names": NAMES, "probes": probe_rows}))

    v30 = out / "v30"
    episodes = [(e, episode_states(e, 80)) for e in range(4)]
    probe_rows = probes(episodes)
    frames = write_meta(v30, "v3.0", episodes, "motors",
                        "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet")
    for file_index, part in enumerate([episodes[:2], episodes[2:]]):
        path = v30 / "data" / "chunk-000" / f"file-{file_index:03d}.parquet"
        path.parent.mkdir(parents=True, exist_ok=True)
        first = sum(len(s) for _, s in episodes[: 2 * file_index])
        pq.write_table(table(part, first, fixed=True), path)
    print(json.dumps({"folder": str(v30), "version": "v3.0", "frames": frames,
                      "episodes": len(episodes), "names": NAMES, "probes": probe_rows}))


if __name__ == "__main__":
    main()
