"""Benchmark: filter-setting evaluations per core-hour with and without shared candidates.

A dense grid -- the approach cone ``[downward, a]`` for a = 90..180 in 5 degree steps times the
facing cone ``[forward, b]`` for b = 10..180 in 10 degree steps (342 settings) -- is evaluated
per seed on FR3 and the Split ALOHA left arm, in one process (one core): every setting with the
candidate cache (``harness.episode.candidate_cache``), and a sample of the same settings and seeds
without it. An evaluation is one (setting, seed) row. The rates are per core-hour (rows over
this process's wall time); their ratio is measured in the same run. The unshared sample's rows
are compared with the shared rows of the same setting and seed: they must be identical.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from harness.benchmarks.framework import Figure, figure
from harness.config import TaskConfig, apply_overrides, load_task
from harness.episode import EpisodeSpec, run_episode
from harness.episode.candidate_cache import WALL_TIME_COLUMNS, CandidateCache
from harness.objects.assets import repo_root
from harness.runs.expansion import point_overrides

SECTION = "sharing"
ROBOTS = ("fr3", "split_aloha_left")
APPROACH_DEG = range(90, 181, 5)
FACING_DEG = range(10, 181, 10)
TARGET_RATE = 1_000_000.0  # evaluations per core-hour with sharing (issue 13)
TARGET_RATIO = 20.0


def grid(task: TaskConfig) -> list[TaskConfig]:
    """The dense approach x facing grid of ``task`` (filters replaced on the robot's axes)."""
    tasks = []
    for approach in APPROACH_DEG:
        for facing in FACING_DEG:
            point = {
                "pick.approach_filter": ["downward", approach],
                "pick.facing_filter": ["forward", facing],
            }
            tasks.append(apply_overrides(task, point_overrides(task, point)))
    return tasks


@dataclass
class RobotRun:
    """Per seed: rows and wall time with sharing, and the unshared sample's."""

    robot: str
    shared_s: list[float] = field(default_factory=list)
    shared_n: list[int] = field(default_factory=list)
    alone_s: list[float] = field(default_factory=list)
    alone_n: list[int] = field(default_factory=list)
    mismatches: int = 0
    executions: int = 0
    tests: int = 0

    def rates(self, shared: bool) -> list[float]:
        seconds, counts = (self.shared_s, self.shared_n) if shared else (self.alone_s, self.alone_n)
        return [3600.0 * n / s for n, s in zip(counts, seconds, strict=True) if s > 0]


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def measure(robot: str, seeds: int, sample: int) -> RobotRun:
    """Run the grid per seed with the cache, then ``sample`` settings of it without."""
    task = load_task(repo_root() / "tasks" / "pick" / f"{robot}.yaml")
    tasks = grid(task)
    scenes: dict[Any, Any] = {}
    run_episode(EpisodeSpec(task=tasks[0], seed=10**6), scenes)  # build the scene first
    picks = np.random.default_rng(0).choice(len(tasks), size=sample, replace=False)
    result = RobotRun(robot)
    for seed in range(seeds):
        cache = CandidateCache()
        start = time.perf_counter()
        rows = [run_episode(EpisodeSpec(task=t, seed=seed), scenes, cache).row for t in tasks]
        result.shared_s.append(time.perf_counter() - start)
        result.shared_n.append(len(rows))
        result.executions += cache.stats.outcomes
        result.tests += cache.stats.verdicts
        start = time.perf_counter()
        alone = [run_episode(EpisodeSpec(task=tasks[i], seed=seed), scenes).row for i in picks]
        result.alone_s.append(time.perf_counter() - start)
        result.alone_n.append(len(alone))
        for index, row in zip(picks.tolist(), alone, strict=True):
            shared_row = rows[index]
            result.mismatches += any(
                not _same(value, shared_row.get(key))
                for key, value in row.items()
                if key not in WALL_TIME_COLUMNS
            )
    return result


def run(quick: bool) -> list[Figure]:
    seeds, sample = (1, 4) if quick else (3, 10)
    figures: list[Figure] = []
    for robot in ROBOTS:
        measured = measure(robot, seeds, sample)
        settings = len(APPROACH_DEG) * len(FACING_DEG)
        what = (
            f"{robot}: {settings} settings x {seeds} seed(s); {measured.tests} candidate tests "
            f"and {measured.executions} executions run for {sum(measured.shared_n)} rows; "
            f"unshared sample {sum(measured.alone_n)} rows, {measured.mismatches} differing "
            "from the shared rows"
        )
        shared = measured.rates(shared=True)
        alone = measured.rates(shared=False)
        figures.append(
            figure(
                SECTION,
                f"evaluations per core-hour, shared ({robot})",
                shared,
                "eval/h",
                target=TARGET_RATE,
                higher_is_better=True,
                notes=what,
            )
        )
        figures.append(
            figure(
                SECTION,
                f"evaluations per core-hour, unshared ({robot})",
                alone,
                "eval/h",
                higher_is_better=True,
                notes="the same settings and seeds, each on its own",
            )
        )
        figures.append(
            figure(
                SECTION,
                f"shared / unshared rate ({robot})",
                [s / a for s, a in zip(shared, alone, strict=True) if a > 0],
                "x",
                target=TARGET_RATIO,
                higher_is_better=True,
                notes="per seed, both measured back to back in this process",
            )
        )
    return figures
