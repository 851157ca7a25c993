"""Benchmark section ``sweeps``: steady-state episodes/s with 1 and 2 workers, and worker memory.

Each round runs the same FR3 episodes (cube, ik mode, TOPP-RA) through the sweep's own
process pool (``harness.runs.executors.run_process_pool``) with 1 and with 2 workers, back to back
in one ``harness bench`` invocation (the order alternates between rounds, so a drift in the
machine's load does not always favour the same side).

Steady state, not start-up: a worker pays spawn + imports + scene build (seconds) before its
first result, which on a short sweep would swamp the 2-worker run. Worker *i* is handed episode
*i* first, so its first result is recognisable; the steady window runs from the moment the last
worker delivered its first result to the last result, and counts the results inside it. (At the
window's start the other worker is part-way through an episode that is counted whole; at its end
it has been idle since its last result. The two edges cancel on average.) Start-up is reported
separately, and so is the end-to-end rate a sweep of this length sees.

The machine is shared, so every round also measures
- the scaling this machine gives perfectly parallel CPU-bound work right now (a pure-Python
  loop in 1 and 2 processes, ``machine.calibrate_scaling``): the reference for the 1.8x target;
- the CPU time other processes used during each pool run (``/proc/stat``), and the load average;
- each episode's own wall time inside the worker, whose 2-worker / 1-worker ratio shows how much
  the workers slow each other down (shared caches, memory bandwidth, other processes).
"""

from __future__ import annotations

import statistics
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from harness.benchmarks.framework import Figure, figure
from harness.benchmarks.machine import (
    CpuUse,
    ScalingCalibration,
    calibrate_scaling,
    cpu_snapshot,
    cpu_use_between,
    load_average,
    spawned_children_peak_mb,
)
from harness.config import TaskConfig, load_task
from harness.episode import EpisodeSpec
from harness.episode.ids import episode_id, episode_seed
from harness.runs.executors import run_process_pool

SECTION = "sweeps"
ROOT = Path(__file__).resolve().parents[2]
SCALING_TARGET = 1.8
# Other processes using more than this many CPUs on average during a pool run: the machine was
# busy, and the 2-worker run could not have had two CPUs to itself.
BUSY_CPUS = 0.25


def _task() -> TaskConfig:
    task = load_task(ROOT / "tasks" / "pick" / "fr3.yaml")
    return task.model_copy(
        update={"pick": task.pick.model_copy(update={"test_mode": "ik", "timing": "toppra"})}
    )


def _episodes(task: TaskConfig, count: int) -> list[EpisodeSpec]:
    return [
        EpisodeSpec(
            episode_id=episode_id(task.name, {}, index),
            task=task,
            task_name=task.name,
            point_id=0,
            point={},
            episode_index=index,
            seed=episode_seed(0, index),
            run="bench",
        )
        for index in range(count)
    ]


@dataclass
class PoolRun:
    """One process-pool run and what it tells about throughput, start-up and memory."""

    workers: int
    episodes: int
    wall_s: float  # the whole run, spawn to the last worker joined
    first_result_s: list[float]  # per worker: run start -> its first episode's result
    steady_count: int  # results after every worker had delivered its first
    steady_window_s: float
    episode_s: list[float]  # each steady episode's wall time inside its worker
    peak_after_first_mb: list[float]  # each worker's peak RSS once all had one episode done
    peak_at_end_mb: list[float]  # each worker's peak RSS at the last result
    row_peak_mb: float  # the largest ``worker_peak_rss_mb`` the rows report (see below)
    successes: int
    cpu: CpuUse
    load_start: list[float] | None
    load_end: list[float] | None

    @property
    def steady_rate(self) -> float:
        return self.steady_count / self.steady_window_s if self.steady_window_s > 0 else 0.0

    @property
    def overall_rate(self) -> float:
        return self.episodes / self.wall_s


def pool_run(task: TaskConfig, workers: int, count: int) -> PoolRun:
    """Run ``count`` episodes on ``workers`` pool workers and time every result's arrival."""
    if count <= workers:
        raise ValueError(f"need more episodes ({count}) than workers ({workers})")
    episodes = _episodes(task, count)
    arrivals: list[tuple[float, dict[str, Any]]] = []
    load_start = load_average()
    before = cpu_snapshot()
    start = time.perf_counter()

    memory: dict[str, dict[int, float]] = {}
    warm_up_left = set(range(workers))

    def on_result(row: dict[str, Any]) -> None:
        arrivals.append((time.perf_counter() - start, row))
        # Read the workers' memory while they are alive: once every worker has finished its
        # first episode, and at the last result (two /proc scans per run, off the hot path).
        warm_up_left.discard(row["episode_index"])
        if not warm_up_left and "first" not in memory:
            memory["first"] = spawned_children_peak_mb()
        if len(arrivals) == count:
            memory["end"] = spawned_children_peak_mb()

    with tempfile.TemporaryDirectory() as run_dir:
        stats = run_process_pool(episodes, Path(run_dir), "none", on_result, workers)
    cpu = cpu_use_between(before, cpu_snapshot())  # after the pool joined its workers
    if stats.crashed or len(arrivals) != count:
        raise RuntimeError(f"pool run lost episodes: {stats.crashed} crashed, {stats.errors}")
    first = [t for t, row in arrivals if row["episode_index"] < workers]
    warm = max(first)
    steady = [(t, row) for t, row in arrivals if t > warm]
    return PoolRun(
        workers=workers,
        episodes=count,
        wall_s=stats.wall_time_s,
        first_result_s=first,
        steady_count=len(steady),
        steady_window_s=arrivals[-1][0] - warm,
        episode_s=[float(row["wall_time_s"]) for _, row in steady],
        peak_after_first_mb=sorted(memory.get("first", {}).values()),
        peak_at_end_mb=sorted(memory.get("end", {}).values()),
        row_peak_mb=max(float(row.get("worker_peak_rss_mb", "nan")) for _, row in arrivals),
        successes=sum(bool(row.get("success")) for _, row in arrivals),
        cpu=cpu,
        load_start=load_start,
        load_end=load_average(),
    )


@dataclass
class Round:
    """One round: the machine's reference scaling, then a 1-worker and a 2-worker run."""

    calibration: ScalingCalibration
    one: PoolRun
    two: PoolRun

    @property
    def scaling(self) -> float:
        return self.two.steady_rate / self.one.steady_rate

    @property
    def slowdown(self) -> float:
        """Median episode time in a worker with 2 workers over that with 1."""
        return statistics.median(self.two.episode_s) / statistics.median(self.one.episode_s)


def measure(rounds: int, count: int, calibration_rounds: int) -> list[Round]:
    task = _task()
    results = []
    for index in range(rounds):
        calibration = calibrate_scaling(2, rounds=calibration_rounds)
        order = (1, 2) if index % 2 == 0 else (2, 1)
        runs = {workers: pool_run(task, workers, count) for workers in order}
        results.append(Round(calibration, runs[1], runs[2]))
    return results


def _others(runs: list[PoolRun]) -> list[float]:
    return [run.cpu.others_cpus for run in runs if run.cpu.others_cpus is not None]


def _scaling_notes(rounds: list[Round]) -> str:
    """What the scaling figure needs next to it: the machine's own scaling and how busy it was."""
    reference = statistics.median(s for r in rounds for s in r.calibration.scalings)
    scaling = statistics.median(r.scaling for r in rounds)
    others = _others([run for r in rounds for run in (r.one, r.two)])
    busiest = max(others) if others else None
    loads = [run.load_start[0] for r in rounds for run in (r.one, r.two) if run.load_start]
    parts = [
        f"steady state; machine reference (CPU-bound loop, same run) {reference:.2f}x, "
        f"sweep at {scaling / reference:.0%} of it",
        f"episode time in a worker {statistics.median(r.slowdown for r in rounds):.2f}x "
        "longer with 2 workers",
    ]
    if busiest is not None:
        state = "busy" if busiest > BUSY_CPUS else "quiet"
        parts.append(
            f"machine {state}: other processes used {statistics.median(others):.2f} CPUs "
            f"(median over runs), up to {busiest:.2f}"
        )
    if loads:
        parts.append(f"1-min load {min(loads):.2f}-{max(loads):.2f} at run starts")
    return "; ".join(parts)


def _memory_figure(runs: list[PoolRun], count: int) -> Figure:
    """Peak RSS per worker, read by the parent from each worker's /proc (VmHWM)."""
    at_end = [m for run in runs for m in run.peak_at_end_mb]
    after_first = [m for run in runs for m in run.peak_after_first_mb]
    row_peak = max(run.row_peak_mb for run in runs)
    if not at_end:  # no /proc: only the rows' ru_maxrss, which includes the parent's size
        return figure(
            SECTION,
            "peak memory per worker (upper bound)",
            [run.row_peak_mb for run in runs],
            "MiB",
            notes="ru_maxrss reported by the workers; includes the parent's RSS at spawn",
        )
    growth = statistics.median(at_end) - statistics.median(after_first) if after_first else 0.0
    return figure(
        SECTION,
        "peak memory per worker",
        at_end,
        "MiB",
        notes=f"VmHWM of each worker after {count} episodes (one sample per worker per run); "
        f"{growth:+.0f} MiB since every worker's first episode. The rows' worker_peak_rss_mb "
        f"(ru_maxrss) says {row_peak:.0f} MiB: it inherits the parent's RSS at spawn",
        extra={"after_first_episode_mb": after_first, "row_worker_peak_rss_mb": row_peak},
    )


def run(quick: bool) -> list[Figure]:
    count = 40 if quick else 120
    rounds = measure(1 if quick else 3, count, calibration_rounds=2 if quick else 3)
    ones = [r.one for r in rounds]
    twos = [r.two for r in rounds]
    runs = ones + twos
    what = f"{count} FR3 episodes per run (ik, toppra), {len(rounds)} round(s)"
    figures = [
        figure(
            SECTION,
            f"episodes/s, {workers} worker{'s' if workers > 1 else ''} (steady state)",
            [run.steady_rate for run in group],
            "ep/s",
            higher_is_better=True,
            notes=f"{what}; from the last worker's first result to the last result",
        )
        for workers, group in ((1, ones), (2, twos))
    ]
    figures.append(_scaling_figure(rounds, runs))
    figures.append(_reference_figure(rounds))
    figures.append(
        figure(
            SECTION,
            "episode time in a worker, 2 workers / 1 worker",
            [r.slowdown for r in rounds],
            "x",
            notes="median per-episode wall time inside the workers; 1.0 = no mutual slowdown",
        )
    )
    figures.append(
        figure(
            SECTION,
            "worker start-up to first result",
            [t for run in runs for t in run.first_result_s],
            "s",
            notes="spawn + imports + scene build + first episode, per worker; not in the "
            "steady-state rates",
        )
    )
    figures.extend(
        figure(
            SECTION,
            f"episodes/s incl. start-up, {workers} worker{'s' if workers > 1 else ''}",
            [run.overall_rate for run in group],
            "ep/s",
            higher_is_better=True,
            notes=f"what a {count}-episode sweep sees end to end",
        )
        for workers, group in ((1, ones), (2, twos))
    )
    figures.append(_memory_figure(runs, count))
    others = _others(runs)
    if others:
        figures.append(
            figure(
                SECTION,
                "other processes' CPU use during the pool runs",
                others,
                "CPUs",
                notes="all CPUs' busy time (/proc/stat) minus this process tree's, per run; "
                f"above {BUSY_CPUS} the machine was busy",
            )
        )
    return figures


def _run_record(run: PoolRun) -> dict[str, Any]:
    """One pool run's figures for the scaling figure's extra."""
    return {
        "workers": run.workers,
        "steady_rate": run.steady_rate,
        "steady_count": run.steady_count,
        "steady_window_s": run.steady_window_s,
        "overall_rate": run.overall_rate,
        "wall_s": run.wall_s,
        "first_result_s": run.first_result_s,
        "successes": run.successes,
        "others_cpus": run.cpu.others_cpus,
        "steal_cpus": run.cpu.steal_cpus,
        "own_cpus": run.cpu.own_cpus,
        "load_start": run.load_start,
        "load_end": run.load_end,
    }


def _scaling_figure(rounds: list[Round], runs: list[PoolRun]) -> Figure:
    """Steady-state scaling from 1 to 2 workers, every pool run in extra."""
    per_run = [_run_record(run) for run in runs]
    return figure(
        SECTION,
        "scaling 1 -> 2 workers (steady state)",
        [r.scaling for r in rounds],
        "x",
        target=SCALING_TARGET,
        higher_is_better=True,
        notes=_scaling_notes(rounds),
        extra={"runs": per_run},
    )


def _reference_figure(rounds: list[Round]) -> Figure:
    """The machine's own scaling of a CPU-bound loop during this section."""
    references = [s for r in rounds for s in r.calibration.scalings]
    return figure(
        SECTION,
        "machine reference: CPU-bound loop, 1 -> 2 processes",
        references,
        "x",
        higher_is_better=True,
        notes="pure-Python loop, processes started before timing; what this machine gave "
        "perfectly parallel work during this section",
        extra={
            "single_s": [s for r in rounds for s in r.calibration.single_s],
            "parallel_s": [p for r in rounds for p in r.calibration.parallel_s],
        },
    )
