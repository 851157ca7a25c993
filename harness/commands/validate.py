"""``harness validate FILE...``: check task and sweep YAML files and say what they hold."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from harness.commands.console import say
from harness.config import (
    ConfigError,
    SweepConfig,
    TaskConfig,
    load_any,
    physics_warnings,
    warning_lines,
)
from harness.config.physics_warnings import WARNING_INPUTS
from harness.errors import HarnessError

if TYPE_CHECKING:
    from harness.interndata import InternDataPick


def describe(kind: str, loaded: object) -> str:
    """One line describing a validated file."""
    if isinstance(loaded, TaskConfig):
        pick = loaded.pick
        filters = {k: v.as_list() for k, v in pick.axis_filters().items()}
        for key in ("approach_filter", "facing_filter"):
            if (spec := getattr(pick, key)) is not None:
                filters[key] = spec.as_list()
        objects = ", ".join(obj.name for obj in loaded.objects)
        return (
            f"task {loaded.name!r}: robot {loaded.robot} arm {loaded.arm}, objects [{objects}], "
            f"filters {filters or 'none'}, test_mode {pick.test_mode}, semantics {pick.semantics}"
        )
    if isinstance(loaded, SweepConfig):
        axes = loaded.axes if loaded.mode == "grid" else loaded.random_axes
        points = 1
        for values in loaded.axes.values():
            points *= len(values)
        if loaded.mode == "random":
            points = loaded.points
        return (
            f"sweep {loaded.name!r}: {len(loaded.tasks)} task(s), {loaded.mode} over "
            f"{list(axes) or 'no axes'} = {points} point(s) x {loaded.episodes_per_point} "
            f"episodes, seed {loaded.seed}"
        )
    return f"{kind} file"


def describe_pick(pick: InternDataPick) -> str:
    """One indented line per InternData pick: where it is, robot, arm, picked object."""
    task = pick.task
    alias = f" ({pick.robot_name!r} in the file)" if pick.robot_name != task.robot else ""
    return (
        f"pick {pick.order} {pick.key}: task {task.name!r}, robot {task.robot}{alias} "
        f"arm {task.arm}, object {task.target_object.name!r}"
    )


def sweep_warning_lines(sweep: SweepConfig, path: str) -> list[str]:
    """Physics warnings of every (task, point) of a sweep, once each: a warning the task file
    causes names the task file; one a swept key causes names the sweep file and the point."""
    from harness.config import apply_overrides
    from harness.runs.expansion import load_sweep_tasks, point_overrides, sweep_points

    lines: list[str] = []
    points = sweep_points(sweep)
    for task in load_sweep_tasks(sweep, Path(path)):
        for point_id, point in enumerate(points):
            try:
                configured = apply_overrides(task, point_overrides(task, point))
            except ConfigError:
                continue  # the expansion reports it
            for key, message in physics_warnings(configured.physics):
                if any(cause in point for cause in WARNING_INPUTS[key]):
                    where, context = path, f"task {task.name!r}, point {point_id} {point}"
                else:
                    where, context = task.source or task.name, f"task {task.name!r}"
                line = f"warning: {where}: {key}: {message} ({context})"
                if line not in lines:
                    lines.append(line)
    return lines


def print_warnings(lines: list[str]) -> None:
    for line in lines:
        say(line, file=sys.stderr)


def _file_warnings(path: str, loaded: object) -> list[str]:
    """The physics warnings of a validated task or sweep file (none when its tasks do not
    load: validate reports only the file itself)."""
    if isinstance(loaded, TaskConfig):
        return warning_lines(loaded, path)
    if isinstance(loaded, SweepConfig):
        try:
            return sweep_warning_lines(loaded, path)
        except HarnessError:
            return []
    return []


def deep_check(path: str, loaded: object) -> None:
    """What a run of the file would load (``harness.runs.preflight``): robot and arm, ``home``,
    meshes, the grasp file, placements; a sweep's every distinct (task, point)."""
    from harness.runs.preflight import check_task, check_tasks

    if isinstance(loaded, TaskConfig):
        print_warnings(check_task(loaded))
    elif isinstance(loaded, SweepConfig):
        from harness.runs.expansion import expand, load_sweep_tasks
        from harness.runs.limits import check_sweep_size

        tasks = load_sweep_tasks(loaded, Path(path))
        check_sweep_size(loaded, len(tasks), file=path)
        episodes = expand(loaded, Path(path), tasks, progress=True)
        check_tasks([e.task for e in episodes[:: loaded.episodes_per_point]])


def main(args: argparse.Namespace) -> int:
    failed = 0
    for path in args.files:
        try:
            kind, loaded = load_any(path)
            if kind == "interndata":
                from harness.interndata import load_interndata_tasks

                picks = load_interndata_tasks(path, asset_root=None, objects={}, check_assets=False)
                say(f"ok {path}: InternDataEngine task file, {len(picks)} pick task(s)")
                for pick in picks:
                    say(f"  {describe_pick(pick)}")
                for pick in picks:
                    print_warnings(warning_lines(pick.task, path, f"pick {pick.order}"))
                continue
            deep_check(path, loaded)
        except ConfigError as exc:
            say(f"error: {exc.one_line()}", file=sys.stderr)
            failed += 1
            continue
        except HarnessError as exc:  # what the run would load: robot, arm, home, files
            say(f"error: {exc}", file=sys.stderr)
            failed += 1
            continue
        say(f"ok {path}: {describe(kind, loaded)}")
        print_warnings(_file_warnings(path, loaded))
    return 1 if failed else 0
