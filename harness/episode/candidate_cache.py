"""Evaluate once per candidate: the per-worker cache shared by points that differ in selection.

A direction filter only *selects* among the same annotated grasps. With the episode's
per-purpose streams (``harness.episode.streams``), what happens to one candidate depends only on
(task physics, seed, candidate): its feasibility verdict and, when it is chosen, its executed
outcome. So two sweep points that differ only in their selection keys (``SELECTION_KEYS``) and
share a seed can share every candidate they both test -- the second point re-runs only the
filters and the draw, and tests or executes only candidates the first never reached. The rows
are identical to unshared ones (tests/test_candidate_cache.py), except for wall-time columns.

``CandidateCache`` is that memory for one worker: ``SeedMemory`` entries keyed by
``evaluation_key(task, seed)`` (the task without its selection keys, plus the seed), kept for the
last ``capacity`` keys (sweeps schedule the points of one key together, ``harness.runs``). An
episode reads and fills its entry through ``harness.episode.evaluation.SeedEvaluation``.
"""

from __future__ import annotations

import json
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from harness.config import TaskConfig
from harness.config.memo import per_task

if TYPE_CHECKING:  # the planners and MuJoCo load only where episodes run
    from harness.episode.records import RowRecord
    from harness.planning.plans import CandidateVerdict

# The pick keys that only choose among candidates (docs/config.md): a point that differs from
# another only in these shares its candidates' evaluations.
SELECTION_KEYS = (
    "filter_x_dir",
    "filter_y_dir",
    "filter_z_dir",
    "approach_filter",
    "facing_filter",
    "direction_to_obj",
)

# Row columns that measure this run's wall clock: never copied from a cached evaluation.
WALL_TIME_COLUMNS = frozenset({"plan_time_s", "ik_time_s", "wall_time_s"})

DEFAULT_CAPACITY = 16


@per_task
def physics_key(task: TaskConfig) -> str:
    """The task without its selection keys, as a canonical string (with its base directory,
    which relative mesh and grasp paths depend on)."""
    dump = task.model_dump(mode="json")
    for key in SELECTION_KEYS:
        dump["pick"].pop(key, None)
    dump["__base_dir__"] = str(task.base_dir())
    return json.dumps(dump, sort_keys=True, default=str)


def evaluation_key(task: TaskConfig, seed: int) -> tuple[str, int]:
    """The key of the evaluations shared by every selection setting of ``task`` at ``seed``."""
    return physics_key(task), int(seed)


@dataclass(frozen=True)
class ResetFacts:
    """What the reset of one (task physics, seed) leaves for candidate selection and tests."""

    T_world_base: np.ndarray
    T_world_object: np.ndarray
    object_init_position: np.ndarray
    q_now: np.ndarray
    settle_steps: int
    unstable: str | None  # why the settling was unstable (the episode stops), else None


@dataclass(frozen=True)
class ExecutedOutcome:
    """The chosen candidate's planned and executed motion: the records of its row columns
    (``harness.episode.records``, wall time excluded) and, when it ended the episode, the failure
    reason and message."""

    records: tuple[RowRecord, ...]
    stop: tuple[str, str] | None = None


@dataclass
class CacheStats:
    """How much the cache saved: lookups answered from memory and evaluations run."""

    reset_hits: int = 0
    resets: int = 0
    verdict_hits: int = 0
    verdicts: int = 0
    outcome_hits: int = 0
    outcomes: int = 0


@dataclass
class SeedMemory:
    """Everything evaluated so far for one (task physics, seed)."""

    reset: ResetFacts | None = None
    verdicts: dict[int, CandidateVerdict] = field(default_factory=dict)
    outcomes: dict[int, ExecutedOutcome] = field(default_factory=dict)
    stats: CacheStats = field(default_factory=CacheStats)  # the owning cache's counters


class CandidateCache:
    """The per-worker memory of seed evaluations, least recently used first out."""

    def __init__(self, capacity: int = DEFAULT_CAPACITY) -> None:
        if capacity < 1:
            raise ValueError("a candidate cache needs room for at least one seed evaluation")
        self.capacity = capacity
        self.stats = CacheStats()
        self._entries: OrderedDict[tuple[str, int], SeedMemory] = OrderedDict()

    def __len__(self) -> int:
        return len(self._entries)

    def memory(self, key: tuple[str, int]) -> SeedMemory:
        """The memory of ``key``, created empty on first use."""
        entry = self._entries.get(key)
        if entry is None:
            entry = SeedMemory(stats=self.stats)
            self._entries[key] = entry
            while len(self._entries) > self.capacity:
                self._entries.popitem(last=False)
        else:
            self._entries.move_to_end(key)
        return entry

    def clear(self) -> None:
        self._entries.clear()
