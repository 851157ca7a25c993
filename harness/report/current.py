"""The task's own setting per robot, arm and object: what "keep the current setting" keeps.

A tie or a run with nothing swept answers "keep the current setting", so the answer must say what
that setting is and whether the sweep measured it. The current setting is the task file's own
grasp filters on the robot's axes (``approach_filter`` resolved through robot.yaml's
``approach_axis``, so ``approach_filter: [downward, 140]`` on the FR3 is its ``filter_z_dir:
[downward, 140]``), plus the task's value of every other swept key. A swept point *is* the
current setting when, applied to the task, it gives the same filters and values.

The tasks come from the run's ``sweep.yaml`` (tasks inlined); a run without a readable one
(a hand-made episodes.csv) has no current setting and the answers say "the task's setting".
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from harness.report.frames import series_rows
from harness.report.labels import format_value
from harness.row import param_columns

Unit = tuple[str, str, str]  # robot, arm, object
FILTER_PARAMS = ("filter_x_dir", "filter_y_dir", "filter_z_dir", "approach_filter", "facing_filter")


@dataclass(frozen=True)
class Current:
    """A unit's current setting: its text and the swept point equal to it (None: not swept)."""

    label: str
    point_id: int | None


def current_settings(run_dir: Path, summary: pd.DataFrame) -> dict[Unit, Current]:
    """Per robot, arm and object of ``summary``, the task's own setting (module docstring),
    compared on every key the sweep sets (one it sets to a single value other than the task's
    own changes the setting too); empty when the run's tasks cannot be read back."""
    params = param_columns(summary.columns)
    try:
        from harness.runs.expansion import load_sweep_tasks
        from harness.runs.rundir import RunDir

        run = RunDir(Path(run_dir))
        if not run.sweep_yaml.is_file():
            return {}
        tasks = {task.name: task for task in load_sweep_tasks(run.load_sweep(), run.sweep_yaml)}
    except Exception:  # an unreadable run has no current setting, not a failed report
        return {}
    found: dict[Unit, Current] = {}
    for row in series_rows(summary):
        unit = (str(row["robot"]), str(row["arm"]), str(row["object"]))
        task = tasks.get(str(row.get("task", "")))
        if task is None:
            continue
        try:
            own = _setting(task, params)
            point = _point_setting(task, row.get("point"), params)
        except Exception:  # a point that no longer applies matches nothing
            continue
        earlier = found.get(unit)
        matched = int(row["point_id"]) if point == own else None
        if earlier is None or (earlier.point_id is None and matched is not None):
            found[unit] = Current(_label(own), matched)
    return found


def _point_setting(task: Any, point: Any, params: list[str]) -> tuple[tuple[str, str], ...]:
    """The setting of ``task`` with one summary row's point applied."""
    from harness.config import apply_overrides
    from harness.runs.expansion import point_overrides

    overrides = json.loads(point) if isinstance(point, str) and point.startswith("{") else {}
    return _setting(apply_overrides(task, point_overrides(task, overrides)), params)


def _setting(task: Any, params: list[str]) -> tuple[tuple[str, str], ...]:
    """The task's filters on the robot's axes, then its value of every other swept key, each as
    ``(key, value text)``."""
    from harness.grasps import resolve_filters
    from harness.robots.facts import reference_convention

    filters = resolve_filters(task.pick, reference_convention(task.robot))
    parts = [(key, format_value(json.dumps(spec.as_list()))) for key, spec in filters.items()]
    if task.pick.direction_to_obj:
        parts.append(("direction_to_obj", str(task.pick.direction_to_obj)))
    data = task.model_dump(mode="json")
    for name in params:
        dotted = name.removeprefix("param.")
        if dotted.split(".")[-1] in FILTER_PARAMS or dotted.endswith(".mesh"):
            continue
        value: Any = data
        for part in dotted.split("."):
            value = value.get(part) if isinstance(value, dict) else None
        parts.append((dotted.split(".")[-1], format_value(json.dumps(value))))
    return tuple(parts)


def _label(setting: tuple[tuple[str, str], ...]) -> str:
    """``filter_x_dir=forward 90, filter_z_dir=downward 140`` (``no filter`` when empty)."""
    return ", ".join(f"{key}={value}" for key, value in setting) or "no filter"
