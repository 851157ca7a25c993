"""Benchmark: filter-setting evaluations per core-hour with and without shared candidates.

A dense grid -- the approach cone ``[downward, a]`` for a = 90..180 in 5 degree steps times the
facing cone ``[forward, b]`` for b = 10..180 in 10 degree steps (342 settings) -- is evaluated
per seed on FR3 and the Split ALOHA left arm, in one process (one core): every setting with the
candidate cache (``harness.episode.candidate_cache``), and a sample of the same settings and seeds
without it. An evaluation is one (setting, seed) row. The rates are per core-hour (rows over
this process's wall time); their ratio is measured in the same run. The unshared sample's rows
are compared with the shared rows of the same setting and seed: they must be identical.

End to end (issue 24): the same grid with as many seeds per setting as one sweep, run as
``harness sweep --workers 1`` in a fresh interpreter (imports, expansion, preflight, the
worker's start-up, row storage, the export and the report all counted), three such sweeps (one
in quick mode) on fresh sweep seeds; its rate is rows per CPU-hour of the command and its worker
together (``RUSAGE_CHILDREN``), beside the bench loop's rate on the same tasks and seeds in this
process (CPU time), and their ratio (target: the end-to-end rate within 2x of the loop's). The
sweep's rows are compared with the loop's, column by column (wall-time, identity and
per-process columns aside): they must be identical.
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
from harness.runs.store import ResultStore, json_default

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
    WALL_TIME_COLUMNS | frozenset(IDENTITY_COLUMNS) | {"worker_peak_rss_mb", "config_sha256"}
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
    """Per sweep: the command's CPU seconds (parent and worker), wall seconds and rows, and the
    bench loop's CPU seconds and rows on the same tasks and seeds."""

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


def sweep_document(robot: str, seeds: int, sweep_seed: int) -> dict[str, Any]:
    """The dense grid as a sweep: ``seeds`` episodes per setting, no recordings."""
    return {
        "name": f"sharing-{robot}",
        "tasks": [str(repo_root() / "tasks" / "pick" / f"{robot}.yaml")],
        "axes": {
            "pick.approach_filter": [["downward", a] for a in APPROACH_DEG],
            "pick.facing_filter": [["forward", b] for b in FACING_DEG],
        },
        "episodes_per_point": seeds,
        "seed": sweep_seed,
        "record": "none",
    }


def _comparable(row: dict[str, Any]) -> dict[str, Any]:
    """A row as the store writes and reads it (JSON), without the columns not compared."""
    data = json.loads(json.dumps(row, default=json_default, allow_nan=True))
    return {k: v for k, v in data.items() if k not in NOT_COMPARED and not k.startswith("param.")}


def _run_sweep_command(document: dict[str, Any], folder: Path) -> tuple[float, float, Path]:
    """``harness sweep`` of ``document`` in a fresh interpreter, one worker, shared: (CPU
    seconds of the command and its worker, wall seconds, run directory)."""
    import yaml

    path = folder / "sweep.yaml"
    path.write_text(yaml.safe_dump(document), encoding="utf-8")
    out = folder / "run"
    main = "from harness.cli import main; raise SystemExit(main())"
    command = [sys.executable, "-c", main, "sweep", str(path), "--out", str(out)]
    command += ["--workers", "1", "--no-progress"]
    cpu, start = _cpu_children(), time.perf_counter()
    subprocess.run(command, check=True, capture_output=True)
    return _cpu_children() - cpu, time.perf_counter() - start, out


def end_to_end(robot: str, sweeps: int, seeds: int) -> EndToEnd:
    """``sweeps`` times: the grid with ``seeds`` episodes per setting as ``harness sweep``, then
    the bench loop on the same tasks and seeds in this process; rows compared."""
    task = load_task(repo_root() / "tasks" / "pick" / f"{robot}.yaml")
    tasks = grid(task)
    scenes: dict[Any, Any] = {}
    run_episode(EpisodeSpec(task=tasks[0], seed=10**6), scenes)  # build the scene first
    result = EndToEnd(robot)
    for sweep_seed in range(sweeps):
        with tempfile.TemporaryDirectory(prefix="harness-sharing-") as folder:
            document = sweep_document(robot, seeds, sweep_seed)
            cpu, wall, out = _run_sweep_command(document, Path(folder))
            stored = {(int(r["point_id"]), int(r["episode_index"])): r
                      for r in ResultStore(out).rows()}  # fmt: skip
        result.sweep_cpu_s.append(cpu)
        result.sweep_wall_s.append(wall)
        result.sweep_n.append(len(stored))
        start, count = time.process_time(), 0
        rows: dict[tuple[int, int], dict[str, Any]] = {}
        for index in range(seeds):
            cache, seed = CandidateCache(), episode_seed(sweep_seed, index)
            for point_id, configured in enumerate(tasks):
                spec = EpisodeSpec(task=configured, seed=seed)
                rows[(point_id, index)] = run_episode(spec, scenes, cache).row
                count += 1
        result.loop_cpu_s.append(time.process_time() - start)
        result.loop_n.append(count)
        for key, row in rows.items():
            theirs = stored.get(key, {})
            result.mismatches += any(
                not _same(v, theirs.get(k)) for k, v in _comparable(row).items()
            )
    return result


def end_to_end_figures(robot: str, measured: EndToEnd, seeds: int) -> list[Figure]:
    """The end-to-end rate, the loop's on the same seeds, and their ratio."""
    sweep, loop = measured.rates(end_to_end=True), measured.rates(end_to_end=False)
    wall = sum(measured.sweep_wall_s) / max(1, len(measured.sweep_wall_s))
    notes = (
        f"{robot}: {len(measured.sweep_n)} sweep(s) of the grid x {seeds} seed(s), "
        f"{sum(measured.sweep_n)} rows (harness sweep --workers 1 in a fresh interpreter, CPU "
        f"of the command and its worker; {wall:.1f} s wall each); {measured.mismatches} rows "
        "differing from the loop's"
    )
    return [
        figure(SECTION, f"end to end: sweep rows per CPU-hour, shared ({robot})", sweep,
               "rows/h", higher_is_better=True, notes=notes),
        figure(SECTION, f"end to end: bench loop rows per CPU-hour, same seeds ({robot})", loop,
               "rows/h", higher_is_better=True, notes="in this process, after each sweep"),
        figure(SECTION, f"end to end / bench loop rate ({robot})",
               [s / lo for s, lo in zip(sweep, loop, strict=True) if lo > 0], "x",
               target=TARGET_END_TO_END, higher_is_better=True,
               notes="per sweep; target: within 2x of the loop (>= 0.5)"),
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
        sweeps = 1 if quick else 3
        figures.extend(end_to_end_figures(robot, end_to_end(robot, sweeps, seeds), seeds))
    return figures
