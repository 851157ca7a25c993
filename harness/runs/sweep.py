"""Sweeps: expand a sweep YAML into episodes and run them on a serial, process-pool or Ray executor.

``run_sweep`` is the orchestration: load the sweep (or the run directory's, to resume), expand it
(``harness.runs.expansion``), skip what the run directory already holds, run the rest on an
executor (``harness.runs.executors``) and finalize the run directory (``harness.runs.rundir``).

Robustness: results stream to the append-only store as episodes finish; a worker that dies (even
by a segfault) turns its episode into an ``error`` row and is replaced; Ctrl-C keeps what finished.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from harness.config import ConfigError, SweepConfig, load_sweep
from harness.files import recording_reads
from harness.runs.executors import RunStats, executor_for
from harness.runs.expansion import expand, load_sweep_tasks
from harness.runs.limits import MAX_EPISODES, MAX_POINTS, check_sweep_size
from harness.runs.pace import Arrivals
from harness.runs.preflight import check_tasks
from harness.runs.progress import SweepProgress
from harness.runs.rundir import RunDir


@dataclass
class SweepOutcome:
    run_dir: Path
    total: int
    skipped_existing: int
    stats: RunStats
    rows: int = 0  # rows in the run directory after the run (the last row of each episode)
    errors: int = 0  # of which ``error`` rows (crashes, input problems; in no success rate)


def default_workers() -> int:
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1)


def prepare_run(
    sweep_path: Path | None, resume_dir: Path | None, out: Path | None, force: bool = False
) -> tuple[SweepConfig, Path | None, RunDir]:
    """Load the sweep (from the run dir when resuming) and choose the run directory."""
    if resume_dir is not None:
        run = RunDir.existing(resume_dir, force=force)
        return run.load_sweep(), run.sweep_yaml, run
    if sweep_path is None:
        raise ConfigError("give a sweep YAML or --resume RUN_DIR")
    sweep = load_sweep(sweep_path)
    return sweep, sweep_path, RunDir(out) if out else RunDir.default(sweep.name)


def check_resume_size(run: RunDir, sweep: SweepConfig, episodes_per_point: int | None) -> None:
    """Refuse ``--episodes-per-point`` that differs from the resumed run's: a resume finishes the
    run as created, so the directory's sweep.yaml always says the run's size."""
    if episodes_per_point in (None, sweep.episodes_per_point):
        return
    raise ConfigError(
        f"--episodes-per-point {episodes_per_point} with --resume: this run has "
        f"{sweep.episodes_per_point} episode(s) per point and a resume finishes it as "
        f"created (start a new run: harness sweep {run.sweep_yaml} --out NEW_DIR "
        f"--episodes-per-point {episodes_per_point})",
        file=run.sweep_yaml,
        key="episodes_per_point",
    )


def with_overrides(
    sweep: SweepConfig,
    record: str | None,
    episodes_per_point: int | None,
    resumed: RunDir | None = None,
) -> SweepConfig:
    """The sweep with the command line's ``--record`` / ``--episodes-per-point``; on a
    ``resumed`` run another ``--episodes-per-point`` is refused (``check_resume_size``)."""
    if resumed is not None:
        check_resume_size(resumed, sweep, episodes_per_point)
    updates: dict[str, Any] = {}
    if record is not None:
        updates["record"] = record
    if episodes_per_point is not None:
        updates["episodes_per_point"] = episodes_per_point
    if not updates:
        return sweep
    return SweepConfig.model_validate({**sweep.model_dump(), **updates})


def run_sweep(
    sweep_path: Path | None = None,
    *,
    resume_dir: Path | None = None,
    out: Path | None = None,
    backend: str = "process",
    workers: int | None = None,
    address: str | None = None,
    record: str | None = None,
    episodes_per_point: int | None = None,
    progress: bool | str = True,
    limit: int | None = None,
    force: bool = False,
    max_episodes: int = MAX_EPISODES,
    retry_errors: bool = False,
    share: bool | None = None,
    max_points: int | None = MAX_POINTS,
) -> SweepOutcome:
    """Expand, run what is missing, store every row, then export, report and record.

    ``progress``: a bar or progress lines (``harness.runs.progress``), a text names them.
    ``limit`` stops after that many new episodes (used to test interruption and resume).
    ``force`` resumes a run whose ``sweep.yaml`` was edited since it was created;
    ``max_episodes`` / ``max_points`` refuse larger sweeps before expanding them (``None``
    points: no limit, for the generated grids of ``harness tune``); ``retry_errors`` runs the
    episodes of a resumed run whose row is an ``error`` again (their new row replaces it);
    ``share`` overrides the sweep's ``share`` (candidate evaluations shared between points that
    differ only in selection keys; the rows are the same either way).
    """
    sweep, source, run = prepare_run(sweep_path, resume_dir, out, force)
    try:
        sweep = with_overrides(sweep, record, episodes_per_point, run if resume_dir else None)
        notes: list[str] = []
        tasks = load_sweep_tasks(sweep, source, notes)
        check_sweep_size(sweep, len(tasks), max_episodes, max_points, source)
        episodes = expand(sweep, source, tasks, progress=bool(progress))
        with recording_reads() as inputs:  # the files the tasks load, hashed for --resume
            check_tasks([e.task for e in episodes[:: sweep.episodes_per_point]])
        if resume_dir is None:
            taken = "run directory already holds a sweep; use --resume to continue it"
            run.create(sweep, tasks, taken=taken, inputs=inputs)
            if notes:
                run.write_notes(notes)
        done_ids = run.completed_ids(retry_errors=retry_errors)
        todo = [e for e in episodes if e.resolved_id not in done_ids]
        if limit is not None:
            todo = todo[:limit]
        workers = workers or sweep.workers or default_workers()
        pool = min(workers, len(todo)) if backend != "serial" else None
        label = progress if isinstance(progress, str) else "sweep"  # e.g. "tune screen"
        already = len(episodes) - len(todo)
        with SweepProgress(len(episodes), already, bool(progress), pool, label) as on_row:
            arrivals = Arrivals()  # for the run's pace

            def on_result(row: dict[str, Any]) -> None:
                run.append(row)
                on_row(row)
                arrivals.mark()

            executor = executor_for(backend, workers, address)
            shared = sweep.share if share is None else share
            stats = executor(todo, run.path, sweep.record, on_result, share=shared)
            stats.arrivals = arrivals.times

        run.finalize()
    finally:
        run.lock.release()
    rows = run.completed_ids(retry_errors=False)
    errors = len(rows - run.completed_ids(retry_errors=True))
    return SweepOutcome(
        run.path, len(episodes), len(episodes) - len(todo), stats, len(rows), errors
    )
