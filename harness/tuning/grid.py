"""The tune grid: which approach and facing cones ``harness tune`` tries, as one sweep.

The grid is robot-neutral (``pick.approach_filter`` x ``pick.facing_filter``), so one sweep spans
robots whose approach axis is EE z (fr3, split_aloha) or EE x (lift2); the sweep's expansion
replaces each task's own filter on that axis (``harness.runs.expansion.filter_overrides``).

Approach cone (angle from base +Z, ``docs/reference-pick-skill.md`` section 4.2):
``[downward, a]`` for a = 90, 90 + step, ... below 180 (``downward 90`` keeps every axis that
points down at all, ``downward 175`` only axes within 5 degrees of straight down; 180 would keep
exactly vertical axes only, an empty mask and the reference's unfiltered fallback), plus ``bands``
equal bands ``[downward, lo, hi]`` over 90-180 (an approach between lo and hi degrees from +Z).

Facing cone (angle from base +X): ``[forward, b]`` for b = 2 step, 4 step, ... up to 180
(``forward 180`` keeps every facing, i.e. no facing filter), plus ``bands`` bands
``[forward, hi, lo]`` over 0-180 (forward bands take the larger angle first).

The task's current setting is added to both axes, so it is a grid point and the best setting is
compared with it on the same seeds. Other axes of a sweep file (``object.mesh``, ...) are kept.

Each axis is deduplicated by what a filter keeps (:func:`filter_key`): ``[downward, 90]`` and the
band ``[downward, 90, 180]`` keep the same axes, ``[forward, 180]`` and ``[forward, 180, 0]``
keep every axis, like no filter at all. The first value of each class stays (the current setting
is the class's first value when it has one); with ``--step 15 --bands 1`` 8 x 7 = 56 points are
7 x 6 = 42 distinct settings.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from harness.config import ConfigError, SweepConfig, TaskConfig, load_sweep, load_task, read_yaml
from harness.config.loading import kind_of
from harness.episode.candidate_cache import SELECTION_KEYS
from harness.grasps import neutral_form, resolve_filters
from harness.grasps.filters import DIRECTION_ROW_SIGN
from harness.robots.facts import reference_convention
from harness.runs.expansion import absolute_paths, load_sweep_tasks

APPROACH_KEY = "pick.approach_filter"
FACING_KEY = "pick.facing_filter"


def _bands(low: float, high: float, count: int) -> list[tuple[float, float]]:
    width = (high - low) / count if count else 0.0
    return [(low + i * width, low + (i + 1) * width) for i in range(count)]


# Pick's only direction names (docs/reference-pick-skill.md section 4.2: "Pick knows only these
# four names"; leftward / rightward are Place's): every cone the filter syntax can state is one
# of these about base X (forward / backward) or base Z (upward / downward).
DIRECTIONS = ("forward", "backward", "upward", "downward")
COARSE_HALF_ANGLES = (45.0, 90.0)  # the coarse pass's cone half-angles (chosen: a quadrant and
# a hemisphere about each direction)


def cone(direction: str, half: float) -> list[Any]:
    """``[direction, angle]`` keeping axes within ``half`` degrees of the named direction (the
    angle is measured from base +X / +Z, so backward and downward take 180 - half)."""
    _, sign = DIRECTION_ROW_SIGN[direction]
    return [direction, float(half if sign > 0 else 180.0 - half)]


def band(direction: str, low: float, high: float) -> list[Any]:
    """``[direction, a1, a2]`` keeping axes between ``low`` and ``high`` degrees from base +X /
    +Z, in the reference's order (forward/upward: larger first; backward/downward: smaller)."""
    _, sign = DIRECTION_ROW_SIGN[direction]
    return [direction, high, low] if sign > 0 else [direction, low, high]


def approach_values(step: int, bands: int, direction: str = "downward") -> list[list[Any]]:
    """Cones of half-angle 90, 90 - step, ... > 0 about ``direction``, then ``bands`` bands over
    its hemisphere (downward: ``[downward, a]`` for a in [90, 180), bands over 90-180)."""
    halves = [90.0 - i * step for i in range(math.ceil(90 / step)) if 90.0 - i * step > 0]
    singles: list[list[Any]] = [cone(direction, h) for h in halves]
    _, sign = DIRECTION_ROW_SIGN[direction]
    low, high = (0.0, 90.0) if sign > 0 else (90.0, 180.0)
    return singles + [band(direction, lo, hi) for lo, hi in _bands(low, high, bands)]


def facing_values(step: int, bands: int, direction: str = "forward") -> list[list[Any]]:
    """Cones of half-angle 2 step, 4 step, ... 180 about ``direction``, then ``bands`` bands
    over 0-180 (forward: ``[forward, b]``, bands ``[forward, hi, lo]``)."""
    halves = [float(b) for b in range(2 * step, 181, 2 * step)]
    if not halves or halves[-1] != 180.0:
        halves.append(180.0)
    singles: list[list[Any]] = [cone(direction, h) for h in halves]
    return singles + [band(direction, lo, hi) for lo, hi in _bands(0.0, 180.0, bands)]


def coarse_values() -> list[list[Any]]:
    """The coarse pass on either axis: a quadrant and a hemisphere about each Pick direction."""
    return [cone(d, h) for d in DIRECTIONS for h in COARSE_HALF_ANGLES]


def direction_of(text: str) -> str | None:
    """The direction name of a filter's JSON (None: no filter)."""
    value = json.loads(text) if text else None
    return str(value[0]) if value else None


def filter_key(value: list[Any] | None) -> tuple[int, float, float] | None:
    """What a neutral filter keeps, as (base row, lowest, highest axis component); None: all.

    ``[dir, a]`` keeps components >= cos a (forward/upward) or <= cos a (backward/downward),
    a band the components between the cosines of its angles (``harness.grasps.filters``).
    """
    if not value:
        return None
    direction, *angles = value
    row, sign = DIRECTION_ROW_SIGN[str(direction)]
    cosines = [math.cos(math.radians(float(a))) for a in angles]
    if len(cosines) == 1:
        low, high = (cosines[0], 1.0) if sign > 0 else (-1.0, cosines[0])
    else:
        low, high = min(cosines), max(cosines)
    low, high = round(max(low, -1.0), 9), round(min(high, 1.0), 9)
    return None if (low, high) == (-1.0, 1.0) else (row, low, high)


def dedupe(values: list[list[Any] | None]) -> list[list[Any] | None]:
    """``values`` without the ones that keep the same axes as an earlier one (first stays)."""
    seen: set[Any] = set()
    kept: list[list[Any] | None] = []
    for value in values:
        key = filter_key(value)
        if key not in seen:
            seen.add(key)
            kept.append(value)
    return kept


def axis_values(grid: list[list[Any]], currents: list[list[Any] | None]) -> list[list[Any] | None]:
    """One axis of the tune: the distinct grid values, then the current settings not in it.

    A grid value that keeps the same axes as a current setting gives way to it, so the
    current setting is run as the task states it.
    """
    claimed = {filter_key(v) for v in currents}
    kept: list[list[Any] | None] = [
        v for v in dedupe([*grid]) if filter_key(v) not in claimed or v in currents
    ]
    return kept + [v for v in dedupe(currents) if filter_key(v) not in map(filter_key, kept)]


def current_setting(task: TaskConfig) -> dict[str, list[Any] | None]:
    """The task's own approach and facing filters in neutral form (None when it sets none)."""
    convention = reference_convention(task.robot)
    neutral = neutral_form(resolve_filters(task.pick, convention), convention)
    return {
        key: (spec.as_list() if (spec := neutral.get(key.removeprefix("pick."))) else None)
        for key in (APPROACH_KEY, FACING_KEY)
    }


@dataclass
class TuneInputs:
    """What a tune is given: its tasks, the sweeps' non-filter axes, the first sweep's seed, and
    for InternDataEngine files their template groups (``harness.tuning.templates``: group name
    -> its tasks, groups of two or more files) and each task's pick block key path."""

    tasks: list[TaskConfig]
    axes: dict[str, list[Any]]
    seed: int | None = None
    groups: dict[str, list[str]] = field(default_factory=dict)
    pick_paths: dict[str, str] = field(default_factory=dict)
    group_lines: list[str] = field(default_factory=list)


def load_inputs(
    paths: list[Path], asset_root: Path | None = None, objects: dict[str, str] | None = None
) -> TuneInputs:
    """Tasks of task, sweep and InternDataEngine files (folders and globs expanded), the
    sweeps' non-filter axes, the first sweep's seed, and the InternDataEngine files' groups."""
    from harness.tuning.templates import body_of, expand_paths, group_files, group_lines

    inputs = TuneInputs([], {})
    bodies: dict[Path, Any] = {}
    tasks_of: dict[Path, list[str]] = {}
    for path in expand_paths(paths):
        data = read_yaml(path).data
        if kind_of(data) == "interndata":
            from harness.interndata import load_interndata_tasks
            from harness.interndata.interpolation import resolve_interpolations

            picks = load_interndata_tasks(
                path, asset_root=asset_root, objects=objects, check_grasps=True
            )
            picks = [p for p in picks if p.task.name not in inputs.pick_paths]
            for pick in picks:
                inputs.tasks.append(absolute_paths(pick.task))
                inputs.pick_paths[pick.task.name] = pick.key
            bodies[path] = body_of(resolve_interpolations(read_yaml(path), path))
            tasks_of[path] = [p.task.name for p in picks]
        elif isinstance(data, dict) and "tasks" in data:
            sweep = load_sweep(path)
            if sweep.mode != "grid":
                raise ConfigError("tune takes grid sweeps (mode: grid)", file=path, key="mode")
            inputs.tasks.extend(load_sweep_tasks(sweep, path))
            inputs.seed = sweep.seed if inputs.seed is None else inputs.seed
            for key, values in sweep.axes.items():
                if key.split(".")[-1] in SELECTION_KEYS:
                    continue  # tune chooses the filters
                merged = inputs.axes.setdefault(key, [])
                merged.extend(v for v in values if v not in merged)
        else:
            inputs.tasks.append(absolute_paths(load_task(path)))
    if not inputs.tasks:
        raise ConfigError("tune needs at least one task or sweep file")
    names = [t.name for t in inputs.tasks]
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise ConfigError(f"task names must be unique within a tune, repeated: {repeated}")
    if bodies:
        groups = group_files(bodies)
        inputs.group_lines = group_lines(groups)
        for group in groups:
            members = [name for f in group.files for name in tasks_of[f]]
            if len(group.files) > 1 and all(len(tasks_of[f]) == 1 for f in group.files):
                inputs.groups[group.name] = members
    return inputs


def objective_tasks(tasks: list[TaskConfig], objective: str) -> list[TaskConfig]:
    """The tasks as the objective needs them run: under ``reference`` nothing the tune decides
    on reads the validity phase (the screening and the race read ``success``), so the phase is
    switched off (``pick.validity: off``; ~37% of an execution's time) wherever the semantics
    allows it (strict's verdict is the phase: kept). The rows then say so as any
    ``validity: off`` row does (``valid`` False, ``invalid_reason`` '', NaN measurements), and
    the candidate cache never shares an execution between a task with the phase and one without
    (``pick.validity`` is part of its physics key)."""
    if objective != "reference":
        return tasks
    from harness.pick.semantics import Semantics  # MuJoCo: only for this objective

    return [
        task
        if Semantics.from_pick(task.pick).validity_is_verdict or not task.pick.validity
        else task.model_copy(update={"pick": task.pick.model_copy(update={"validity": False})})
        for task in tasks
    ]


def tune_sweep(
    tasks: list[TaskConfig],
    extra_axes: dict[str, list[Any]],
    *,
    step: int,
    bands: int,
    episodes: int,
    seed: int,
    name: str = "tune",
    directions: tuple[str, str] = ("downward", "forward"),
    coarse: bool = False,
) -> SweepConfig:
    """The tune sweep: tasks x (approach cones x facing cones x other axes) x seeds. ``coarse``:
    the coarse pass over every direction (:func:`coarse_values` on both axes); else the fine
    grid about ``directions`` (approach, facing)."""
    if not 1 <= step <= 90:
        raise ConfigError(f"--step {step}: expected 1 to 90 degrees")
    if bands < 0:
        raise ConfigError(f"--bands {bands}: expected 0 or more")
    currents = [current_setting(task) for task in tasks]
    if coarse:
        grid_a, grid_f = coarse_values(), coarse_values()
    else:
        grid_a = approach_values(step, bands, directions[0])
        grid_f = facing_values(step, bands, directions[1])
    approach = axis_values(grid_a, [c[APPROACH_KEY] for c in currents])
    facing = axis_values(grid_f, [c[FACING_KEY] for c in currents])
    data = {
        "name": name,
        "tasks": [
            task.model_dump(mode="json", exclude={"source"}, exclude_none=True) for task in tasks
        ],
        "axes": {APPROACH_KEY: approach, FACING_KEY: facing, **extra_axes},
        "episodes_per_point": episodes,
        "seed": seed,
        "record": "none",
    }
    return SweepConfig.model_validate(data)


def merged_sweep(first: SweepConfig, second: SweepConfig) -> SweepConfig:
    """``first`` with ``second``'s filter values added to its two axes (deduplicated by what
    they keep): a sweep holding every setting of both passes, for the race's seeds."""
    data = first.model_dump(mode="json")
    for key in (APPROACH_KEY, FACING_KEY):
        data["axes"][key] = dedupe([*first.axes[key], *second.axes[key]])  # type: ignore[list-item]
    return SweepConfig.model_validate(data)
