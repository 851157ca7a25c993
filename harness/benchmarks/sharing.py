"""Benchmark: filter-setting evaluations per core-hour with and without shared candidates.

A dense grid -- the approach cone ``[downward, a]`` for a = 90..180 in 5 degree steps times the
facing cone ``[forward, b]`` for b = 10..180 in 10 degree steps (342 settings) -- is evaluated
per seed on FR3 and the Split ALOHA left arm, in one process (one core): every setting with the
candidate cache (``harness.episode.candidate_cache``), and a sample of the same settings and seeds
without it. An evaluation is one (setting, seed) row. The rates are per core-hour (rows over
this process's wall time); their ratio is measured in the same run. The unshared sample's rows
are compared with the shared rows of the same setting and seed: they must be identical.

End to end (issue 24): the same grid as a sweep, ``harness sweep --workers 1`` in a fresh
interpreter (imports, expansion, preflight, the worker's start-up, row storage, export and the
report all counted), one sweep per seed; its rate is rows per CPU-hour of the command and its
worker together (``RUSAGE_CHILDREN``), beside the bench loop's rate on the same seed in this
process (CPU time), and the ratio of the two (target: the end-to-end rate within 2x of the
loop's). The sweep's rows are compared with the loop's, column by column (wall-time, identity
and per-process columns aside): they must be identical.
"""

from __future__ import annotations

import json
import math
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from harness.benchmarks.framework import Figure, figure
from harness.config import TaskConfig, apply_overrides, load_task
from harness.episode import EpisodeSpec, run_episode
from harness.episode.candidate_cache import WALL_TIME_COLUMNS, CandidateCache
from harness.episode.ids import episode_seed
from harness.objects.assets import repo_root
from harness.row import IDENTITY_COLUMNS
from harness.runs.expansion import point_overrides
from harness.runs.store import ResultStore, _json_default

SECTION = "sharing"
ROBOTS = ("fr3", "split_aloha_left")
APPROACH_DEG = range(90, 181, 5)
FACING_DEG = range(10, 181, 10)
TARGET_RATE = 1_000_000.0  # evaluations per core-hour with sharing (issue 13)
TARGET_RATIO = 20.0
TARGET_END_TO_END = 0.5  # end-to-end rate / bench loop rate (issue 24: within 2x)
# Columns that differ between a sweep's row and the loop's by construction: the wall clock, the
# row's identity in its run, the worker process's memory, the run's config hash.
NOT_COMPARED = (
    WALL_TIME_COLUMNS
    | frozenset(IDENTITY_COLUMNS)
    | {"worker_peak_rss_mb", "config_sha256", "engine"}
)


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


def _cpu_children() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


@dataclass
class EndToEnd:
    """Per seed: the sweep command's CPU seconds and rows, the loop's on the same seed."""

    robot: str
    sweep_cpu_s: list[float] = field(default_factory=list)
    sweep_wall_s: list[float] = field(default_factory=list)
    sweep_n: list[int] = field(default_factory=list)
    loop_cpu_s: list[float] = field(default_factory=list)
    loop_n: list[int] = field(default_factory=list)
    mismatches: int = 0

    def rates(self, end_to_end: bool) -> list[float]:
        pairs = (
            zip(self.sweep_n, self.sweep_cpu_s, strict=True)
            if end_to_end
            else zip(self.loop_n, self.loop_cpu_s, strict=True)
        )
        return [3600.0 * n / s for n, s in pairs if s > 0]


def sweep_document(robot: str, seed: int) -> dict[str, Any]:
    """The dense grid as a sweep of one seed (sweep seed ``seed``, no recordings)."""
    return {
        "name": f"sharing-{robot}",
        "tasks": [str(repo_root() / "tasks" / "pick" / f"{robot}.yaml")],
        "axes": {
            "pick.approach_filter": [["downward", a] for a in APPROACH_DEG],
            "pick.facing_filter": [["forward", b] for b in FACING_DEG],
        },
        "episodes_per_point": 1,
        "seed": seed,
        "record": "none",
    }


def _comparable(row: dict[str, Any]) -> dict[str, Any]:
    """A row as the store writes and reads it (JSON), without the columns not compared."""
    data = json.loads(json.dumps(row, default=_json_default, allow_nan=True))
    return {k: v for k, v in data.items() if k not in NOT_COMPARED and not k.startswith("param.")}


def end_to_end(robot: str, seeds: int) -> EndToEnd:
    """Per seed: the grid as ``harness sweep`` (fresh interpreter, one worker, shared), then the
    bench loop on the same tasks and seed in this process; rows compared."""
    import yaml

    task = load_task(repo_root() / "tasks" / "pick" / f"{robot}.yaml")
    tasks = grid(task)
    scenes: dict[Any, Any] = {}
    run_episode(EpisodeSpec(task=tasks[0], seed=10**6), scenes)  # build the scene first
    result = EndToEnd(robot)
    for sweep_seed in range(seeds):
        with tempfile.TemporaryDirectory(prefix="harness-sharing-") as folder:
            path = Path(folder) / "sweep.yaml"
            path.write_text(yaml.safe_dump(sweep_document(robot, sweep_seed)), encoding="utf-8")
            out = Path(folder) / "run"
            command = [sys.executable, "-c", "from harness.cli import main; raise SystemExit(main())",
                       "sweep", str(path), "--out", str(out), "--workers", "1", "--no-progress"]  # fmt: skip
            cpu, start = _cpu_children(), time.perf_counter()
            subprocess.run(command, check=True, capture_output=True)
            result.sweep_wall_s.append(time.perf_counter() - start)
            result.sweep_cpu_s.append(_cpu_children() - cpu)
            stored = {int(r["point_id"]): r for r in ResultStore(out).rows()}
        result.sweep_n.append(len(stored))
        seed = episode_seed(sweep_seed, 0)
        cache = CandidateCache()
        start = time.process_time()
        rows = [run_episode(EpisodeSpec(task=t, seed=seed), scenes, cache).row for t in tasks]
        result.loop_cpu_s.append(time.process_time() - start)
        result.loop_n.append(len(rows))
        for point_id, row in enumerate(rows):
            mine, theirs = _comparable(row), stored.get(point_id, {})
            result.mismatches += any(not _same(v, theirs.get(k)) for k, v in mine.items())
    return result


def end_to_end_figures(robot: str, measured: EndToEnd) -> list[Figure]:
    """The end-to-end rate, the loop's on the same seeds, and their ratio."""
    sweep, loop = measured.rates(end_to_end=True), measured.rates(end_to_end=False)
    wall = sum(measured.sweep_wall_s) / max(1, len(measured.sweep_wall_s))
    notes = (
        f"{robot}: {sum(measured.sweep_n)} rows in {len(measured.sweep_n)} sweep(s) of the grid "
        f"(one seed each, harness sweep --workers 1, fresh interpreter; {wall:.1f} s wall each); "
        f"{measured.mismatches} rows differing from the loop's"
    )
    return [
        figure(SECTION, f"end to end: sweep rows per CPU-hour, shared ({robot})", sweep,
               "rows/h", higher_is_better=True, notes=notes),
        figure(SECTION, f"end to end: bench loop rows per CPU-hour, same seeds ({robot})", loop,
               "rows/h", higher_is_better=True, notes="in this process, after each sweep"),
        figure(SECTION, f"end to end / bench loop rate ({robot})",
               [s / lo for s, lo in zip(sweep, loop, strict=True) if lo > 0], "x",
               target=TARGET_END_TO_END, higher_is_better=True,
               notes="per seed; target: within 2x of the loop (>= 0.5)"),
    ]  # fmt: skip


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
        figures.extend(end_to_end_figures(robot, end_to_end(robot, seeds)))
    return figures
