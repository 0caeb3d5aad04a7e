"""imitate from Python: costmaps and policies learned from robot demonstrations.

The Rust crate is the one implementation; this package calls it in-process. Arrays are
NumPy arrays (costmaps and features float32 with row 0 the map's southern edge, as the
artifacts store them), stage and pipeline runs take the parameters of the command line
and the pipeline YAML, and errors are `ImitateError` (`InputError` for a bad file or
value, `UsageError` for parameters that cannot work) with the command line's messages.
"""

from __future__ import annotations

import json
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native
from ._native import ImitateError, InputError, Policy, UsageError, __version__

PathLike = Union[str, "os.PathLike[str]"]

__all__ = [
    "Costmap",
    "Features",
    "ImitateError",
    "InputError",
    "Policy",
    "Route",
    "UsageError",
    "append_round",
    "compute_features",
    "plan",
    "read_costmap",
    "read_features",
    "read_metrics",
    "read_paths",
    "run_pipeline",
    "run_stage",
    "stage_kinds",
]


@dataclass(frozen=True)
class Costmap:
    """One map's costs: `costs[row, col]` (row 0 south), blocked cells not finite."""

    name: str
    costs: np.ndarray
    georef: dict


@dataclass(frozen=True)
class Features:
    """One map's feature stack: `values[feature, row, col]`, named by `names`."""

    name: str
    names: list
    values: np.ndarray
    spec: dict


@dataclass(frozen=True)
class Route:
    """A planned path: `cells[i] = (row, col)`, and its cost in cost x metres."""

    cells: np.ndarray
    cost: float


def stage_kinds() -> list:
    """The stage kinds `run_stage` and pipelines know."""
    return list(_native.stage_kinds())


def run_stage(kind: str, **params: Any) -> dict:
    """Runs one stage with the parameters of its pipeline entry (`with:`) and command.

    Returns its report: `output` folder, `digest`, `summary`. Paths are relative to
    the working directory. Example: `run_stage("learch", dataset="ds",
    features="fs", out="costmap", rounds=40)`.
    """
    return json.loads(_native.run_stage(kind, json.dumps(params, default=os.fspath)))


def run_pipeline(
    pipeline: PathLike, *, force: bool = False, only: Optional[str] = None, jobs: int = 1
) -> list:
    """Runs a pipeline file as `imitate run` does: only stale stages run, recorded in
    its lock file and cache. Returns each stage's outcome in the run's order."""
    return json.loads(_native.run_pipeline(os.fspath(pipeline), force, only, jobs))


def read_costmap(path: PathLike, map: Optional[str] = None) -> Costmap:
    """A costmap from an artifact folder (`map` picks one of several), a costmap table,
    a GeoTIFF or a MovingAI map."""
    name, costs, georef = _native.read_costmap(os.fspath(path), map)
    return Costmap(name, costs, json.loads(georef))


def read_features(path: PathLike) -> Features:
    """One feature table of a features artifact (`features/<map>.parquet`)."""
    name, names, values, spec = _native.read_features(os.fspath(path))
    return Features(name, list(names), values, json.loads(spec))


def compute_features(map_table: PathLike, spec: Mapping[str, Any]) -> Tuple[list, np.ndarray]:
    """Features of a map table by a feature spec (the features stage's `spec`, e.g.
    `{"bank": "auto", "bias": True}`): (names, values[feature, row, col])."""
    names, values = _native.compute_features(os.fspath(map_table), json.dumps(dict(spec)))
    return list(names), values


def read_paths(path: PathLike) -> list:
    """A paths table (`paths.parquet` of a dataset or costmap artifact) as a list of
    (episode, map name, cells[i] = (row, col))."""
    return list(_native.read_paths(os.fspath(path)))


def read_metrics(artifact: PathLike) -> dict:
    """An artifact's `metrics.json`."""
    with open(Path(artifact) / "metrics.json", encoding="utf-8") as f:
        return json.load(f)


def plan(
    costs: np.ndarray,
    start: Tuple[int, int],
    goal: Tuple[int, int],
    *,
    resolution: float = 1.0,
    resolution_y: Optional[float] = None,
    connectivity: int = 8,
    corner_cutting: bool = True,
) -> Optional[Route]:
    """The cheapest path from `start` to `goal` ((row, col)) on `costs[row, col]`
    (row 0 south; cells that are not finite and positive are blocked), by the planner
    LEARCH uses. Cells are `resolution` metres wide and `resolution_y` tall. `None`
    when the goal cannot be reached."""
    grid = np.ascontiguousarray(costs, dtype=np.float32)
    found = _native.plan(
        grid,
        (int(start[0]), int(start[1])),
        (int(goal[0]), int(goal[1])),
        float(resolution),
        None if resolution_y is None else float(resolution_y),
        int(connectivity),
        bool(corner_cutting),
    )
    return None if found is None else Route(*found)


def append_round(
    dataset: PathLike,
    table: Any,
    *,
    observations: Sequence[str],
    action: str,
    episode: str = "episode_index",
    executed: Optional[str] = None,
) -> Tuple[int, bool]:
    """Appends one round to a DAgger dataset: expert demonstrations, or with `executed`
    a round your policy drove and the teacher labelled (as `imitate dagger add
    --demonstrations`). `table` is a Parquet path (or a list of them), a pyarrow Table,
    or a pandas or polars DataFrame. Columns are named as on the command line
    (`name`, or `name[i]` for one element of a list column). Returns (round, whether it
    is new: the same rows twice append nothing)."""
    columns = dict(
        observations=[str(o) for o in observations],
        action=str(action),
        episode=str(episode),
        executed=None if executed is None else str(executed),
    )
    if isinstance(table, (str, os.PathLike)):
        return _native.append_round(os.fspath(dataset), [os.fspath(table)], **columns)
    if isinstance(table, (list, tuple)) and all(isinstance(t, (str, os.PathLike)) for t in table):
        return _native.append_round(os.fspath(dataset), [os.fspath(t) for t in table], **columns)
    with tempfile.TemporaryDirectory(prefix="imitate-round-") as folder:
        path = os.path.join(folder, "round.parquet")
        _write_parquet(table, path)
        return _native.append_round(os.fspath(dataset), [path], **columns)


def _write_parquet(table: Any, path: str) -> None:
    """A pyarrow Table, or a pandas or polars DataFrame, as a Parquet file."""
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError as e:  # pragma: no cover - depends on the user's environment
        raise UsageError(f"appending a table needs pyarrow ({e}); or pass a Parquet path") from e
    if hasattr(table, "to_arrow") and not isinstance(table, pa.Table):
        table = table.to_arrow()  # polars
    elif not isinstance(table, pa.Table):
        table = pa.Table.from_pandas(table, preserve_index=False)
    pq.write_table(table, path)
