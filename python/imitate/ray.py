"""imitate on a Ray cluster. `learch`: actors plan shards of the training examples, the
driver merges their statistics in example order and fits each round's learner.
`ingest`: robot logs decoded one task each, the dataset written on the driver.
`dagger_round`: episodes in the user's own environment, one task each, appended to a
DAgger dataset as one round. `run_pipeline` (and `python -m imitate.ray run PIPELINE`):
a pipeline's stale stages as tasks, with `imitate run`'s keys, lock file and cache.

Each actor loads the run's inputs once (the demonstrations, split as every run of the
parameters splits them, and the features of the maps its shard's examples lie on) and
keeps its shard of the training examples; per round the driver sends the model and gets back each shard's statistics.
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

import argparse
import json
import os
import sys
from typing import Any, Callable, Optional, Sequence

from . import _native

# The learch stage's parameters that name files.
_PATH_PARAMETERS = ("dataset", "features", "out")


class _LearchWorker:
    """One actor: a shard of the training examples, its inputs loaded once."""

    def __init__(self, params: str, start: int, stop: int, workdir: str) -> None:
        # Relative paths in the parameters are relative to the driver's directory.
        os.chdir(workdir)
        self._shard = _native.LearchShard(params, start, stop)

    def plan(self, model: str, corridor: int) -> str:
        return self._shard.plan(model, corridor)

    def examples(self) -> int:
        return self._shard.examples

    def peak_memory(self) -> int:
        """The actor process's peak resident memory so far, in bytes."""
        import resource

        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


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
    monitoring (or, in tests, for killing an actor). Each actor loads the features of
    only the maps its shard's examples lie on; the report's `actors_peak_memory` lists
    each actor's peak resident memory in bytes.
    """
    text = json.dumps(_absolute(params), default=os.fspath)
    return _learch_on_actors(text, actors=actors, num_cpus_per_actor=num_cpus_per_actor,
                             max_restarts=max_restarts, on_round=on_round)


def _learch_on_actors(
    text: str,
    *,
    actors: int,
    num_cpus_per_actor: float = 1,
    max_restarts: int = 3,
    on_round: Optional[Callable[[int, Sequence[Any]], None]] = None,
    extra_deps: Sequence[str] = (),
) -> dict:
    """`learch` with its parameters as JSON (paths relative to this directory, which the
    actors take as theirs too) and the pipeline's extra dependencies."""
    import ray

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
    workdir = os.getcwd()
    workers = [worker.remote(text, start, stop, workdir)
               for start, stop in shards(examples, actors)]
    rounds = [0]

    def plan(model: str, corridor: int) -> list:
        if on_round is not None:
            on_round(rounds[0], workers)
        rounds[0] += 1
        return ray.get([w.plan.remote(model, corridor) for w in workers])

    try:
        report = json.loads(_native.run_learch_distributed(text, plan, list(extra_deps)))
        report["actors_peak_memory"] = ray.get([w.peak_memory.remote() for w in workers])
        return report
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


# ---------------------------------------------------------------------------------
# Pipelines: every stage that must run is a Ray task.


def _run_stage(workdir: str, kind: str, params: str, extra_deps: list) -> str:
    # The pipeline's paths are relative to the directory it was run from.
    os.chdir(workdir)
    return _native.run_stage(kind, params, extra_deps)


def run_pipeline(
    pipeline: Any,
    *,
    jobs: Optional[int] = None,
    force: bool = False,
    only: Optional[str] = None,
    num_cpus_per_stage: float = 1,
    max_retries: int = 3,
    learch_actors: Optional[int] = None,
) -> list:
    """Runs a pipeline file as `imitate run` does, on the connected Ray cluster: the
    driver (this process) builds the DAG, decides what is stale from the lock file,
    restores cached outputs and records every stage; each stage that must run is a Ray
    task (retried when its worker dies), up to `jobs` independent ones at once (by
    default as many as the cluster's CPUs allow). The working directory, every input
    and every output must be on a filesystem all nodes see, at the same path. Returns
    each stage's outcome (`name`, `kind`, `out`, `reasons`, `ran`, `digest`,
    `summary`) in the run's order: the digests `imitate run` gives. With
    `learch_actors`, a learch stage is run as `learch` runs, its rounds planned on that
    many actors (of `num_cpus_per_stage` CPUs each), rather than as one task."""
    import ray

    if jobs is None:
        cpus = ray.cluster_resources().get("CPU", 1)
        jobs = max(1, int(cpus // max(num_cpus_per_stage, 1e-9)))
    workdir = os.getcwd()
    threads = str(max(1, int(num_cpus_per_stage)))
    task = ray.remote(
        num_cpus=num_cpus_per_stage,
        max_retries=max_retries,
        runtime_env={"env_vars": {"RAYON_NUM_THREADS": threads}},
    )(_run_stage)

    def execute(kind: str, params: str, extra_deps: list) -> str:
        if kind == "learch" and learch_actors:
            report = _learch_on_actors(params, actors=learch_actors,
                                       num_cpus_per_actor=num_cpus_per_stage,
                                       max_restarts=max_retries, extra_deps=extra_deps)
            report.pop("actors_peak_memory", None)
            return json.dumps(report)
        return ray.get(task.remote(workdir, kind, params, list(extra_deps)))

    text = _native.run_pipeline(os.fspath(pipeline), force=force, only=only, jobs=jobs,
                                execute=execute)
    return json.loads(text)


def main(argv: Optional[Sequence[str]] = None) -> int:
    """`python -m imitate.ray run PIPELINE [--address ADDR] ...`: prints what
    `imitate run` prints (each stage's outcome on stderr, `name, output, digest` lines
    on stdout). Exit 0, 2 on bad input, 1 when a stage fails."""
    parser = argparse.ArgumentParser(
        prog="python -m imitate.ray",
        description="Runs an imitate pipeline on a Ray cluster.")
    commands = parser.add_subparsers(dest="command", required=True)
    run = commands.add_parser("run", help="run a pipeline's stale stages as Ray tasks")
    run.add_argument("pipeline", help="the pipeline file (YAML)")
    run.add_argument("--address", default=None,
                     help="the Ray cluster (e.g. auto, HEAD_IP:6379, ray://HOST:10001); "
                          "without it a local one is started")
    run.add_argument("--jobs", type=int, default=None,
                     help="stages at once (default: the cluster's CPUs / --cpus-per-stage)")
    run.add_argument("--cpus-per-stage", type=float, default=1,
                     help="CPUs each stage task holds and computes on (default 1)")
    run.add_argument("--force", action="store_true", help="rerun stages even when up to date")
    run.add_argument("--stage", default=None, help="only this stage")
    run.add_argument("--learch-actors", type=int, default=None,
                     help="plan a learch stage's rounds on this many actors "
                          "(default: the stage is one task)")
    args = parser.parse_args(argv)

    import ray

    from . import ImitateError, InputError, UsageError

    ray.init(address=args.address, log_to_driver=False)
    try:
        outcomes = run_pipeline(args.pipeline, jobs=args.jobs, force=args.force,
                                only=args.stage, num_cpus_per_stage=args.cpus_per_stage,
                                learch_actors=args.learch_actors)
    except (InputError, UsageError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except ImitateError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    finally:
        ray.shutdown()
    for o in outcomes:
        if not o["reasons"]:
            print(f"{o['name']}: up to date", file=sys.stderr)
        else:
            print(f"{o['name']}: {o['summary']} ({'; '.join(o['reasons'])})", file=sys.stderr)
    for o in outcomes:
        print(f"{o['name']}\t{o['out']}\t{o['digest']}")
    return 0


if __name__ == "__main__":
    # Run as the package's module, so that the tasks Ray ships name `imitate.ray`.
    from imitate.ray import main as _main

    sys.exit(_main())
