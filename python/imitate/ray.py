"""imitate on a Ray cluster. `learch`: actors plan shards of the training examples, the
driver merges their statistics in example order and fits each round's learner.
`ingest`: robot logs decoded one task each, the dataset written on the driver.
`dagger_round`: episodes in the user's own environment, one task each, appended to a
DAgger dataset as one round.

Each actor loads the run's inputs once (every map's features and the demonstrations,
split as every run of the parameters splits them) and keeps its shard of the training
examples; per round the driver sends the model and gets back each shard's statistics.
The artifact is the one `imitate learch` (or `run_stage("learch", ...)`) writes with
the same parameters, byte for byte, whatever the number of nodes and actors: the
statistics are merged in example order and the learner is fitted on the driver.

Inputs and the output must lie on a filesystem every node sees; paths are made
absolute before they are sent. `imitate` must be installed on every node (`pip
install .` from a checkout, or the wheel it builds). Ray restarts an actor that dies
and retries its task (`max_restarts`, `max_task_retries`): the round's result is the
same, since an actor's work depends only on the parameters and the model.
"""

from __future__ import annotations

import json
import os
from typing import Any, Callable, Optional, Sequence

from . import _native

# The learch stage's parameters that name files.
_PATH_PARAMETERS = ("dataset", "features", "out")


class _LearchWorker:
    """One actor: a shard of the training examples, its inputs loaded once."""

    def __init__(self, params: str, start: int, stop: int) -> None:
        self._shard = _native.LearchShard(params, start, stop)

    def plan(self, model: str) -> str:
        return self._shard.plan(model)

    def examples(self) -> int:
        return self._shard.examples


def _absolute(params: dict) -> dict:
    resolved = dict(params)
    for key in _PATH_PARAMETERS:
        if key in resolved and resolved[key] is not None:
            resolved[key] = os.path.abspath(os.fspath(resolved[key]))
    if resolved.get("references"):
        resolved["references"] = [os.path.abspath(os.fspath(r)) for r in resolved["references"]]
    return resolved


def shards(examples: int, actors: int) -> list:
    """Contiguous (start, stop) ranges of `examples`, as even as they can be, for at
    most `actors` actors and never an empty one."""
    k = max(1, min(actors, examples))
    return [(i * examples // k, (i + 1) * examples // k) for i in range(k)]


def learch(
    *,
    actors: int = 2,
    num_cpus_per_actor: float = 1,
    max_restarts: int = 3,
    on_round: Optional[Callable[[int, Sequence[Any]], None]] = None,
    **params: Any,
) -> dict:
    """Runs the learch stage with `params` (those of its YAML entry and command:
    `dataset`, `features`, `out`, `rounds`, ...) on the connected Ray cluster (call
    `ray.init(address=...)` first; without it Ray starts a local one), planning on
    `actors` actors. Returns the stage's report: `output`, `digest`, `summary`.

    `on_round(round, actors)` is called before each round's plans are sent, for
    monitoring (or, in tests, for killing an actor).
    """
    import ray

    text = json.dumps(_absolute(params), default=os.fspath)
    examples = _native.learch_training_examples(text)
    # An actor plans on as many threads as the CPUs it holds, not on every core of
    # its node.
    threads = str(max(1, int(num_cpus_per_actor)))
    worker = ray.remote(
        num_cpus=num_cpus_per_actor,
        max_restarts=max_restarts,
        max_task_retries=max_restarts,
        runtime_env={"env_vars": {"RAYON_NUM_THREADS": threads}},
    )(_LearchWorker)
    workers = [worker.remote(text, start, stop) for start, stop in shards(examples, actors)]
    rounds = [0]

    def plan(model: str) -> list:
        if on_round is not None:
            on_round(rounds[0], workers)
        rounds[0] += 1
        return ray.get([w.plan.remote(model) for w in workers])

    try:
        return json.loads(_native.run_learch_distributed(text, plan))
    finally:
        for w in workers:
            ray.kill(w)


# ---------------------------------------------------------------------------------
# Ingest: one Ray task per log.

# The ingest stage's parameters that name files.
_INGEST_PATHS = ("demonstrations", "out")
_INGEST_PATH_LISTS = ("maps", "lerobot", "logs")


def _ingest_absolute(params: dict) -> dict:
    resolved = dict(params)
    for key in _INGEST_PATHS:
        if resolved.get(key) is not None:
            resolved[key] = os.path.abspath(os.fspath(resolved[key]))
    for key in _INGEST_PATH_LISTS:
        if resolved.get(key):
            resolved[key] = [os.path.abspath(os.fspath(p)) for p in resolved[key]]
    return resolved


def _ingest_log(params: str, index: int) -> tuple:
    return _native.ingest_log_part(params, index)


def ingest(*, max_retries: int = 3, num_cpus_per_task: float = 1, **params: Any) -> dict:
    """Runs the ingest stage with `params` (those of its YAML entry and command: `logs`,
    `maps`, `demonstrations`, `goal_topic`, `split`, `out`, ...) on the connected Ray
    cluster: each log is decoded by a task of its own (retried when its worker dies),
    its map and demonstrations come back as Parquet bytes, and the driver writes the
    dataset. The artifact is the one `imitate ingest` writes with the same parameters,
    byte for byte. Returns the stage's report: `output`, `digest`, `summary`."""
    import ray

    text = json.dumps(_ingest_absolute(params), default=os.fspath)
    threads = str(max(1, int(num_cpus_per_task)))
    task = ray.remote(
        num_cpus=num_cpus_per_task,
        max_retries=max_retries,
        runtime_env={"env_vars": {"RAYON_NUM_THREADS": threads}},
    )(_ingest_log)

    def decode(logs: list) -> list:
        return ray.get([task.remote(text, i) for i in range(len(logs))])

    return json.loads(_native.run_ingest_distributed(text, decode))


# ---------------------------------------------------------------------------------
# DAgger rollouts in the user's own environment, one Ray task per episode.


def _actions(value: Any) -> list:
    """An action (a number or a vector of them) as a list of floats."""
    import numpy as np

    return [float(v) for v in np.atleast_1d(np.asarray(value, dtype=np.float64)).ravel()]


_POLICIES: dict = {}


def _policy(path: str):
    """A policy artifact, loaded once per worker process."""
    if path not in _POLICIES:
        _POLICIES[path] = _native.Policy(path)
    return _POLICIES[path]


def episode(
    make_env: Callable[[], Any],
    teacher: Callable[[Any], Any],
    policy: Optional[str] = None,
    *,
    seed: int,
    max_steps: int,
    beta: float = 0.0,
) -> dict:
    """One episode in a gymnasium-style environment (`reset(seed=...)`, `step(action)`
    giving (observation, reward, terminated, truncated, info)), the teacher labelling
    every state visited. Without `policy` the teacher drives; with one (a policy
    artifact folder) the policy drives, except that each step the teacher's action is
    executed instead with probability `beta` (drawn from a generator seeded by `seed`).
    Depends only on its arguments, so a retried task gives the same episode.

    Returns the observations, the teacher's labels, the executed actions (lists of
    float lists, one per step) and the return.
    """
    import numpy as np

    env = make_env()
    rng = np.random.default_rng(seed)
    learner = _policy(os.path.abspath(policy)) if policy is not None else None
    observation, _ = env.reset(seed=seed)
    observations, labels, executed, total = [], [], [], 0.0
    for _ in range(max_steps):
        x = _actions(observation)
        label = _actions(teacher(observation))
        action = label
        if learner is not None and not rng.random() < beta:
            action = [float(a) for a in learner.act(np.asarray([x]))[0]]
        observations.append(x)
        labels.append(label)
        executed.append(action)
        step = np.asarray(action, dtype=np.float32)
        shape = getattr(getattr(env, "action_space", None), "shape", None)
        if shape is not None and shape != step.shape:
            step = step.reshape(shape)
        observation, reward, terminated, truncated, _ = env.step(step)
        total += float(reward)
        if terminated or truncated:
            break
    close = getattr(env, "close", None)
    if close is not None:
        close()
    return {"observations": observations, "labels": labels, "executed": executed,
            "return": total}


def rollouts(
    make_env: Callable[[], Any],
    teacher: Callable[[Any], Any],
    policy: Optional[str] = None,
    *,
    seeds: Sequence[int],
    max_steps: int,
    beta: float = 0.0,
    local: bool = False,
    max_retries: int = 3,
) -> list:
    """`episode` for every seed, one Ray task each (retried when a worker dies), in
    seed order; `local=True` runs them here one after another (the same episodes)."""
    kwargs = dict(max_steps=max_steps, beta=beta)
    if local:
        return [episode(make_env, teacher, policy, seed=int(s), **kwargs) for s in seeds]
    import ray

    one_thread = {"env_vars": {"RAYON_NUM_THREADS": "1"}}
    task = ray.remote(max_retries=max_retries, runtime_env=one_thread)(episode)
    path = None if policy is None else os.path.abspath(os.fspath(policy))
    return ray.get([task.remote(make_env, teacher, path, seed=int(s), **kwargs) for s in seeds])


def dagger_round(
    dataset: Any,
    make_env: Callable[[], Any],
    teacher: Callable[[Any], Any],
    policy: Optional[Any] = None,
    *,
    seeds: Sequence[int],
    max_steps: int,
    beta: float = 0.0,
    local: bool = False,
) -> tuple:
    """One DAgger round in the user's environment: the episodes of `rollouts` (on the
    cluster), appended to the DAgger dataset at `dataset` as one round (episode i the
    i-th seed's; with a policy, the executed actions beside the teacher's labels).
    The dataset must hold observations and actions of the environment's sizes
    (`imitate dagger init DS --env log --observations ... --actions ...`). Returns
    (round, whether it is new) and the episodes' returns."""
    import pyarrow as pa

    episodes = rollouts(make_env, teacher, policy, seeds=seeds, max_steps=max_steps,
                        beta=beta, local=local)
    ids, observations, labels, executed = [], [], [], []
    for i, e in enumerate(episodes):
        ids.extend([i] * len(e["observations"]))
        observations.extend(e["observations"])
        labels.extend(e["labels"])
        executed.extend(e["executed"])
    columns = {
        "episode_index": pa.array(ids, pa.int64()),
        "observation": pa.array(observations, pa.list_(pa.float64())),
        "action": pa.array(labels, pa.list_(pa.float64())),
    }
    if policy is not None:
        columns["action_executed"] = pa.array(executed, pa.list_(pa.float64()))
    from . import append_round

    appended = append_round(dataset, pa.table(columns), observations=["observation"],
                            action="action",
                            executed="action_executed" if policy is not None else None)
    return appended, [e["return"] for e in episodes]
