"""Type stubs of imitate's compiled core (`python/src/lib.rs`)."""

from typing import Callable, Optional

import numpy as np
import numpy.typing as npt

__version__: str

class ImitateError(Exception):
    """An error of imitate's, with the command line's message."""

class InputError(ImitateError):
    """A file or value given to imitate is missing, unreadable or not what it should be."""

class UsageError(ImitateError):
    """Parameters that cannot work together."""

class Policy:
    """A policy from a policy artifact (`dagger train`, the dagger stage)."""

    digest: str
    observation_names: list[str]
    def __init__(self, path: str) -> None: ...
    def act(self, observations: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """Actions [n, actions] for observations [n, observations]."""

def run_stage(kind: str, params: str, extra_deps: list[str] = ...) -> str: ...
def stage_kinds() -> list[str]: ...
def run_pipeline(
    pipeline: str,
    force: bool = False,
    only: Optional[str] = None,
    jobs: int = 1,
    execute: Optional[Callable[[str, str, list[str]], str]] = None,
) -> str: ...
def read_costmap(path: str, map: Optional[str] = None) -> tuple[str, npt.NDArray[np.float32], str]: ...
def read_features(path: str) -> tuple[str, list[str], npt.NDArray[np.float32], str]: ...
def read_paths(path: str) -> list[tuple[str, str, npt.NDArray[np.uint32]]]: ...
def compute_features(path: str, spec: str) -> tuple[list[str], npt.NDArray[np.float32]]: ...
def plan(
    costs: npt.NDArray[np.float32],
    start: tuple[int, int],
    goal: tuple[int, int],
    resolution: float = 1.0,
    resolution_y: Optional[float] = None,
    connectivity: int = 8,
    corner_cutting: bool = True,
) -> Optional[tuple[npt.NDArray[np.uint32], float]]: ...
def append_round(
    dataset: str,
    tables: list[str],
    observations: list[str],
    action: str,
    episode: str = "episode_index",
    executed: Optional[str] = None,
) -> tuple[int, bool]: ...
def learch_training_examples(params: str) -> int: ...

class LearchShard:
    """A worker's share of a LEARCH run: training examples start..stop, inputs loaded once."""

    examples: int
    def __init__(self, params: str, start: int, stop: int) -> None: ...
    def plan(self, model: str) -> str:
        """The shard's statistics (JSON) under the model (JSON), in example order."""

def run_learch_distributed(
    params: str, plan: Callable[[str], list[str]], extra_deps: list[str] = ...
) -> str: ...
def ingest_log_part(params: str, index: int) -> tuple[Optional[bytes], bytes]:
    """Log `index` of the ingest parameters' logs: its map and demonstrations (Parquet)."""

def run_ingest_distributed(
    params: str, decode: Callable[[list[str]], list[tuple[Optional[bytes], bytes]]]
) -> str: ...
