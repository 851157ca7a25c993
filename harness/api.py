"""The Python API: load a task, run an episode, run a sweep, read a run -- from a script or a
notebook, with the same code paths as the command line.

``run_sweep`` (``harness.runs.sweep``) takes a sweep YAML path; ``sweep`` here also takes a
``SweepConfig`` or a plain dict (task paths relative to the current directory) and returns the
episode table. Process-pool sweeps are safe to start from a script without an
``if __name__ == "__main__":`` guard: workers never re-import the calling script.
"""

from __future__ import annotations

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
) -> pd.DataFrame:
    """Run a sweep and return its episode table (one row per episode, ``episodes.csv``'s
    columns). ``config``: a sweep YAML path, a ``SweepConfig`` or a dict in the YAML's shape.
    The run directory (report, recordings) is ``out``, else ``reports/<name>-<time>``."""
    from harness.report.finish import finish_run  # scipy, matplotlib: only when sweeping

    if isinstance(config, (str, Path)):
        outcome = run_sweep(
            Path(config), out=_out(out), workers=workers, backend=backend, progress=progress
        )
        finish_run(outcome.run_dir)
        return load_run(outcome.run_dir)
    data = config.model_dump(mode="json") if isinstance(config, SweepConfig) else dict(config)
    data["tasks"] = [_absolute_task(entry) for entry in data.get("tasks", [])]
    with tempfile.TemporaryDirectory(prefix="harness-sweep-") as folder:
        path = Path(folder) / "sweep.yaml"
        path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
        outcome = run_sweep(
            path, out=_out(out), workers=workers, backend=backend, progress=progress
        )
    finish_run(outcome.run_dir)
    return load_run(outcome.run_dir)


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
