"""The Python API: load a task, run an episode, run a sweep, read a run -- from a script or a
notebook, with the same code paths as the command line.

``run_sweep`` (``harness.runs.sweep``) takes a sweep YAML path; ``sweep`` here also takes a
``SweepConfig`` or a plain dict (task paths relative to the current directory) and returns the
episode table. Process-pool sweeps are safe to start from a script without an
``if __name__ == "__main__":`` guard: workers never re-import the calling script.
"""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pandas as pd
import yaml

from harness.config import SweepConfig, TaskConfig, apply_overrides
from harness.config import load_task as _load_task
from harness.episode import EpisodeResult, EpisodeSpec
from harness.episode import run_episode as _run_episode
from harness.runs.store import ResultStore
from harness.runs.sweep import run_sweep

PathLike = str | Path


def load_task(path: PathLike, overrides: Mapping[str, Any] | None = None) -> TaskConfig:
    """A task YAML as a validated ``TaskConfig``; ``overrides`` are dotted keys
    (``{"pick.filter_z_dir": ["downward", 150]}``), as ``harness run --set``."""
    task = _load_task(Path(path))
    if overrides:
        task = apply_overrides(task, dict(overrides))
    return task


def run_episode(
    task: TaskConfig | PathLike, seed: int = 0, *, record: PathLike | None = None
) -> EpisodeResult:
    """Run one episode of ``task`` (a ``TaskConfig`` or a task YAML path) with ``seed``.

    Returns the ``EpisodeResult``: ``.row`` (the columns of ``episodes.csv``), ``.success``,
    ``.failure_reason``, ``.trace``. ``record`` writes the episode's Rerun recording there.
    """
    config = task if isinstance(task, TaskConfig) else load_task(task)
    result = _run_episode(EpisodeSpec(task=config, seed=int(seed)))
    if record is not None:
        from harness.viz.recording import record_episode  # rerun: only when asked

        record_episode(result, Path(record), config)
    return result


def sweep(
    config: SweepConfig | Mapping[str, Any] | PathLike,
    *,
    out: PathLike | None = None,
    workers: int | None = None,
    backend: str = "process",
    progress: bool = False,
    resume: bool = False,
    overwrite: bool = False,
) -> pd.DataFrame:
    """Run a sweep and return its episode table (one row per episode, ``episodes.csv``'s
    columns). ``config``: a sweep YAML path, a ``SweepConfig`` or a dict in the YAML's shape.
    The run directory (report, recordings) is ``out``, else ``reports/<name>-<time>``.

    When ``out`` already holds a run: ``resume=True`` runs only its missing episodes (the
    run's own sweep: a ``config`` that differs from it is refused), ``overwrite=True`` deletes
    that run and starts again; without either, ``HarnessError`` says which to pass. A script
    that calls ``sweep(..., out=X, resume=True)`` can therefore run again and again."""
    from harness.report.finish import finish_run  # scipy, matplotlib: only when sweeping

    target = _out(out)
    existing = _existing_run(target, resume, overwrite)
    with tempfile.TemporaryDirectory(prefix="harness-sweep-") as folder:
        if isinstance(config, (str, Path)):
            path = Path(config)
        else:
            data = (
                config.model_dump(mode="json") if isinstance(config, SweepConfig) else dict(config)
            )
            data["tasks"] = [_absolute_task(entry) for entry in data.get("tasks", [])]
            path = Path(folder) / "sweep.yaml"
            path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
        if existing is not None:
            _check_same_sweep(path, existing)
            outcome = run_sweep(
                resume_dir=existing, workers=workers, backend=backend, progress=progress
            )
        else:
            outcome = run_sweep(
                path, out=target, workers=workers, backend=backend, progress=progress
            )
    finish_run(outcome.run_dir)
    return load_run(outcome.run_dir)


def _existing_run(out: Path | None, resume: bool, overwrite: bool) -> Path | None:
    """The run in ``out`` to resume; None to start one there (after deleting the run it held
    with ``overwrite``)."""
    from harness.errors import HarnessError
    from harness.runs.rundir import SWEEP_YAML, RunDir

    if resume and overwrite:
        raise HarnessError("sweep(): pass resume=True or overwrite=True, not both")
    if out is None or not (out / SWEEP_YAML).is_file():
        if resume and out is None:
            raise HarnessError("sweep(resume=True) needs out= (the run directory to continue)")
        return None
    if resume:
        return out
    if not overwrite:
        raise HarnessError(
            f"{out} already holds a run: pass resume=True to run its missing episodes, or "
            "overwrite=True to delete it and start again"
        )
    run = RunDir.existing(out, force=True)  # refuses a run another process is writing
    run.lock.release()
    shutil.rmtree(out)
    return None


def _check_same_sweep(path: Path, run_dir: Path) -> None:
    """Refuse to resume ``run_dir`` with a sweep other than the one it was created with."""
    from harness.config import load_sweep
    from harness.errors import HarnessError
    from harness.runs.expansion import load_sweep_tasks
    from harness.runs.rundir import RunDir, resolved_sweep_document

    given = load_sweep(path)
    document = resolved_sweep_document(given, load_sweep_tasks(given, path))
    stored = RunDir(run_dir).load_sweep().model_dump(mode="json")
    if yaml.safe_load(yaml.safe_dump(document)) != yaml.safe_load(yaml.safe_dump(stored)):
        raise HarnessError(
            f"{run_dir} holds a run of another sweep (its sweep.yaml differs from this "
            "config): overwrite=True replaces it, or choose another out="
        )


def load_run(run_dir: PathLike) -> pd.DataFrame:
    """The episode table of a run directory (typed; the last row per episode id)."""
    return ResultStore(Path(run_dir)).load()


def _out(out: PathLike | None) -> Path | None:
    return Path(out) if out is not None else None


def _absolute_task(entry: Any) -> Any:
    """Task paths of a dict sweep are relative to the current directory."""
    if isinstance(entry, str) and not entry.startswith(("interndata:",)):
        return str(Path(entry).resolve())
    return entry
