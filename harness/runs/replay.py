"""Replaying one stored episode: rebuild its spec from the run directory, run it again, and
check that the new row equals the stored one.

Episodes are deterministic in (task, point, seed), so any row of a run can be re-run to get what
the row alone cannot hold: the recording, a video, a debugger session. A replay that does not
reproduce its row is reported column by column (a changed harness version, a different machine's
libraries), never silently accepted.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from harness.config import ConfigError
from harness.runs.expansion import expand, load_sweep_tasks
from harness.runs.rundir import SWEEP_YAML
from harness.runs.store import ResultStore

# Columns that measure the machine or name files, not the episode.
UNREPRODUCIBLE = {
    "wall_time_s",
    "ik_time_s",
    "plan_time_s",
    "worker_peak_rss_mb",
    "recording",
    "recording_error",
    "run",
    "harness_version",
    "mujoco_version",
}


def find_episode(run_dir: Path, episode_id: str) -> tuple[Any, dict[str, Any]]:
    """The ``EpisodeSpec`` of ``episode_id`` in ``run_dir`` and its stored row."""
    from harness.config import load_sweep

    store = ResultStore(run_dir)
    frame = store.load()
    matches = frame[frame["episode_id"] == episode_id]
    if matches.empty:
        raise ConfigError(f"no episode {episode_id!r} in this run", file=run_dir)
    stored = matches.iloc[-1].to_dict()
    sweep_yaml = run_dir / SWEEP_YAML
    sweep = load_sweep(sweep_yaml)
    tasks = load_sweep_tasks(sweep, sweep_yaml)
    for spec in expand(sweep, sweep_yaml, tasks):
        if spec.resolved_id == episode_id:
            return spec, stored
    raise ConfigError(
        f"episode {episode_id!r} is stored but its sweep.yaml no longer expands to it",
        file=sweep_yaml,
    )


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    if a is None or (isinstance(a, float) and math.isnan(a)):
        return b is None or b == "" or (isinstance(b, float) and math.isnan(b))
    if isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        return float(a) == float(b)
    return a == b or str(a) == str(b)


def row_differences(stored: dict[str, Any], replayed: dict[str, Any]) -> list[str]:
    """``column: stored -> replayed`` for every reproducible column that differs."""
    out = []
    for column, value in stored.items():
        if column in UNREPRODUCIBLE or column not in replayed:
            continue
        if not _same(value, replayed[column]):
            out.append(f"{column}: {value!r} -> {replayed[column]!r}")
    return out
