#!/usr/bin/env python3
"""DAgger with your own simulator, closed through files: gymnasium's Pendulum-v1 driven
by an exported imitate policy through onnxruntime, labelled by a teacher, each round
appended to an imitate DAgger dataset, the next policy trained and exported.

The teacher swings the pendulum up by pumping energy and balances it with a linear
state feedback near the top; the learner (`--learner`, regression trees by default) is
a class the teacher is not in. Behaviour cloning gets the same number of teacher labels
per iteration, but always from states the teacher itself visits.

Per iteration:
  1. run the current policy (`policy.onnx`, onnxruntime; the teacher in iteration 1)
     for --episodes episodes, the teacher labelling every state it visits;
  2. write the round as Parquet (`episode_index`, `observation.state`, `action` = the
     teacher's label, `action_executed` = what was done) and
     `imitate dagger add DS --demonstrations ROUND --executed action_executed`;
  3. `imitate dagger train DS --out P --learner L`, `imitate export P --format onnx`;
  4. score the new policy on --test-episodes fixed starts: mean return and the share
     of episodes that fail (not held upright over the last 20 steps).

usage: pendulum_dagger.py [--imitate PATH] [--seeds 0,1,2] [--iterations 10]
                          [--episodes 5] [--test-episodes 20] [--learner tree]
                          [--train '--depth 8']
                          [--method dagger,bc] [--json] [--work DIR]
Needs gymnasium, onnxruntime, pyarrow and numpy (scripts/python-deps.sh installs them).
"""

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile

import gymnasium as gym
import numpy as np
import onnxruntime
import pyarrow as pa
import pyarrow.parquet as pq

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_IMITATE = os.path.join(HERE, "..", "target", "release", "imitate")
STEPS = 200  # Pendulum-v1's time limit


def teacher(observation):
    """Energy pumping far from the top, linear state feedback near it (Pendulum-v1:
    theta'' = 15 sin(theta) + 3u, |u| <= 2, upright at theta = 0)."""
    cos, sin, omega = observation
    theta = math.atan2(sin, cos)
    if cos > 0.9 and abs(omega) < 3.0:
        u = -(13.3 * theta + 3.3 * omega)
    else:
        energy = 0.5 * omega * omega + 15.0 * (cos - 1.0)
        u = 0.6 * (0.0 - energy) * omega
        if abs(omega) < 0.05:  # at rest hanging down: start the swing
            u = 1.0
    return float(np.clip(u, -2.0, 2.0))


class Onnx:
    """A policy exported by `imitate export --format onnx`."""

    def __init__(self, path):
        self.session = onnxruntime.InferenceSession(path, providers=["CPUExecutionProvider"])

    def __call__(self, observation):
        row = np.asarray([observation], dtype=np.float32)
        (action,) = self.session.run(["action"], {"observation": row})
        return float(np.clip(action[0][0], -2.0, 2.0))


def episode(policy, seed, label=True):
    """One episode of `policy`; (rows, return, failed) with the teacher's label of every
    state visited."""
    env = gym.make("Pendulum-v1")
    observation, _ = env.reset(seed=seed)
    rows, total, angles = [], 0.0, []
    for _ in range(STEPS):
        executed = policy(observation)
        if label:
            rows.append((observation.astype(float).tolist(), teacher(observation), executed))
        observation, reward, terminated, truncated, _ = env.step(np.array([executed], dtype=np.float32))
        total += float(reward)
        angles.append(abs(math.atan2(observation[1], observation[0])))
        if terminated or truncated:
            break
    env.close()
    failed = max(angles[-20:]) > 0.3
    return rows, total, failed


def write_round(path, episodes):
    ids, states, labels, executed = [], [], [], []
    for e, rows in enumerate(episodes):
        for observation, label, done in rows:
            ids.append(e)
            states.append(observation)
            labels.append([label])
            executed.append([done])
    vector = lambda n: pa.list_(pa.float32(), n)  # noqa: E731
    table = pa.table({
        "episode_index": pa.array(ids, pa.int64()),
        "observation.state": pa.array(states, vector(3)),
        "action": pa.array(labels, vector(1)),
        "action_executed": pa.array(executed, vector(1)),
    })
    pq.write_table(table, path)


def imitate(binary, *args):
    done = subprocess.run([binary, *args], capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"imitate {' '.join(args)} failed ({done.returncode}):\n{done.stderr}")
    return done.stdout


def run(binary, method, seed, args, work):
    """One method and seed: per iteration, the test score of the policy trained then."""
    dataset = os.path.join(work, f"{method}-{seed}", "dataset")
    imitate(binary, "dagger", "init", dataset, "--env", "log",
            "--observations", "cos_theta,sin_theta,theta_dot", "--actions", "torque")
    policy = None
    scores = []
    rng = np.random.default_rng(seed)
    for iteration in range(1, args.iterations + 1):
        driver = teacher if (policy is None or method == "bc") else policy
        episodes = [episode(driver, int(s))[0]
                    for s in rng.integers(0, 2**31, size=args.episodes)]
        round_file = os.path.join(work, f"{method}-{seed}", f"round-{iteration:02}.parquet")
        write_round(round_file, episodes)
        imitate(binary, "dagger", "add", dataset, "--demonstrations", round_file,
                "--executed", "action_executed")
        trained = os.path.join(work, f"{method}-{seed}", f"policy-{iteration:02}")
        imitate(binary, "dagger", "train", dataset, "--out", trained,
                "--learner", args.learner, *args.train.split())
        exported = trained + "-onnx"
        imitate(binary, "export", trained, "--out", exported, "--format", "onnx")
        policy = Onnx(os.path.join(exported, "policy.onnx"))
        tests = [episode(policy, 10_000 + k, label=False) for k in range(args.test_episodes)]
        scores.append({
            "iteration": iteration,
            "labels": sum(len(e) for e in episodes) * iteration,
            "mean_return": float(np.mean([t[1] for t in tests])),
            "failures_per_episode": float(np.mean([t[2] for t in tests])),
        })
    return scores


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--imitate", default=DEFAULT_IMITATE)
    parser.add_argument("--seeds", default="0,1,2")
    parser.add_argument("--iterations", type=int, default=10)
    parser.add_argument("--episodes", type=int, default=5)
    parser.add_argument("--test-episodes", type=int, default=20)
    parser.add_argument("--learner", default="tree")
    parser.add_argument("--train", default="--depth 8",
                        help="more `imitate dagger train` options, as one string")
    parser.add_argument("--method", default="dagger,bc")
    parser.add_argument("--work", help="keep the datasets and policies here")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()

    teacher_tests = [episode(teacher, 10_000 + k, label=False) for k in range(args.test_episodes)]
    results = {
        "teacher": {
            "mean_return": float(np.mean([t[1] for t in teacher_tests])),
            "failures_per_episode": float(np.mean([t[2] for t in teacher_tests])),
        },
        "runs": [],
    }
    with tempfile.TemporaryDirectory() as tmp:
        work = args.work or tmp
        for method in args.method.split(","):
            for seed in [int(s) for s in args.seeds.split(",")]:
                results["runs"].append({
                    "method": method,
                    "seed": seed,
                    "iterations": run(args.imitate, method, seed, args, work),
                })
    if args.json:
        print(json.dumps(results))
        return
    t = results["teacher"]
    print(f"teacher: mean return {t['mean_return']:.1f}, "
          f"failures per episode {t['failures_per_episode']:.2f}")
    print("method  seed  iteration  labels  mean return  failures per episode")
    for r in results["runs"]:
        for it in r["iterations"]:
            print(f"{r['method']:<7} {r['seed']:>4}  {it['iteration']:>9}  {it['labels']:>6}  "
                  f"{it['mean_return']:>11.1f}  {it['failures_per_episode']:>20.2f}")


if __name__ == "__main__":
    main()
