"""LEARCH on a Ray cluster: actors plan shards of the training examples, the driver
merges their statistics in example order and fits each round's learner.

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
