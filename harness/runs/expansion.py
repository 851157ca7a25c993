"""Sweep expansion: a sweep YAML's tasks x points x seeds as a list of episode specs.

A sweep is tasks x points x seeds. Points come from a grid (cartesian product of ``axes``) or from
``points`` random draws over ``random_axes``; each axis is a dotted task key such as
``pick.approach_filter`` or ``object.friction``. Robot-neutral keys (``approach_filter``,
``facing_filter``) let one sweep span robots with different end-effector conventions.

Determinism: the episode seed depends only on (sweep seed, episode index), so episode k of every
point sees the same object placement and home noise -- points are compared on common random
numbers. Episode ids hash (task, point, episode index), so resuming runs exactly what is missing
(``harness.episode.ids``).
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from harness.config import (
    ConfigError,
    SweepConfig,
    TaskConfig,
    apply_overrides,
    load_task,
    validate_model,
)
from harness.episode.ids import episode_id, episode_seed
from harness.episode.spec import EpisodeSpec
from harness.robots.facts import reference_convention


def absolute_paths(task: TaskConfig) -> TaskConfig:
    """Make object mesh / grasp paths absolute so the task no longer depends on its file."""
    base = task.base_dir()
    objects = []
    for obj in task.objects:
        update: dict[str, Any] = {}
        for key in ("mesh", "grasps"):
            value = getattr(obj, key)
            if value and not Path(value).is_absolute() and (base / value).exists():
                update[key] = str((base / value).resolve())
        objects.append(obj.model_copy(update=update) if update else obj)
    return task.model_copy(update={"objects": objects})


INTERNDATA_ENTRY_KEYS = ("interndata", "asset_root", "objects")


def load_sweep_tasks(
    sweep: SweepConfig, sweep_path: Path | None, notes: list[str] | None = None
) -> list[TaskConfig]:
    """Resolve the sweep's task entries (paths, inline tasks, InternDataEngine files).

    What each InternDataEngine file contributes and skips (other skills, ignored keys,
    approximations) is appended to ``notes`` when given.
    """
    base = sweep_path.resolve().parent if sweep_path else Path.cwd()
    tasks: list[TaskConfig] = []
    for index, entry in enumerate(sweep.tasks):
        if isinstance(entry, str):
            path = Path(entry) if Path(entry).is_absolute() else base / entry
            try:
                tasks.append(absolute_paths(load_task(path)))
            except ConfigError as exc:
                if exc.file is None or "file not found" in exc.message:
                    raise ConfigError(
                        f"task file {str(path)!r}: {exc.message}",
                        file=sweep_path,
                        key=f"tasks[{index}]",
                    ) from None
                raise
        elif "interndata" in entry:
            from harness.interndata import load_interndata_tasks, note_lines

            unknown = [k for k in entry if k not in INTERNDATA_ENTRY_KEYS]
            if unknown:
                raise ConfigError(
                    f"unknown key {unknown[0]!r} in an interndata entry; expected "
                    f"{', '.join(INTERNDATA_ENTRY_KEYS)}",
                    file=sweep_path,
                    key=f"tasks[{index}].{unknown[0]}",
                )
            path = Path(entry["interndata"])
            path = path if path.is_absolute() else base / path
            if not path.is_file():
                raise ConfigError(
                    f"InternDataEngine task file not found: {path}. It lies outside this "
                    "repository: fetch the InternDataEngine task files and assets (the examples "
                    "expect them in ../shared/datasets/interndata-examples beside the "
                    "repository) or point 'interndata' and 'objects' at your copy; "
                    "docs/interndata.md",
                    file=sweep_path,
                    key=f"tasks[{index}].interndata",
                )
            root = entry.get("asset_root")
            objects = {k: str(base / v) for k, v in (entry.get("objects") or {}).items()}
            picks = load_interndata_tasks(
                path, asset_root=base / root if root else None, objects=objects, check_grasps=True
            )
            if notes is not None:
                notes.extend(note_lines(path, picks))
            tasks.extend(absolute_paths(pick.task) for pick in picks)
        else:
            data = {"source": str(sweep_path) if sweep_path else None, **entry}
            task = validate_model(TaskConfig, data, None, ("tasks", index))
            tasks.append(absolute_paths(task))
    names = [task.name for task in tasks]
    duplicates = sorted({name for name in names if names.count(name) > 1})
    if duplicates:
        raise ConfigError(
            f"task names must be unique within a sweep, repeated: {duplicates}",
            file=sweep_path,
            key="tasks",
        )
    return tasks


def sweep_points(sweep: SweepConfig) -> list[dict[str, Any]]:
    """The parameter points: grid product in axis order, or seeded random draws."""
    if sweep.mode == "grid":
        keys = list(sweep.axes)
        if not keys:
            return [{}]
        return [
            dict(zip(keys, values, strict=True))
            for values in itertools.product(*(sweep.axes[k] for k in keys))
        ]
    rng = np.random.default_rng(np.random.SeedSequence([sweep.seed, 0x5EED]))
    points: list[dict[str, Any]] = []
    seen: set[str] = set()
    for _ in range(sweep.points):
        point: dict[str, Any] = {}
        for key, axis in sweep.random_axes.items():
            if axis.choices is not None:
                point[key] = axis.choices[int(rng.integers(len(axis.choices)))]
            else:
                assert axis.low is not None and axis.high is not None  # RandomAxis: one form
                point[key] = float(rng.uniform(axis.low, axis.high))
        identity = json.dumps(point, sort_keys=True, default=str)  # as the episode id sees it
        if identity not in seen:  # a repeated draw would share episode ids: run it once
            seen.add(identity)
            points.append(point)
    if len(points) < sweep.points:
        print(
            f"note: sweep {sweep.name!r}: {sweep.points} random draws gave {len(points)} "
            f"distinct points (random_axes with choices repeat); each distinct point runs once",
            file=sys.stderr,
        )
    return points


FILTER_KEYS = {"x": "filter_x_dir", "y": "filter_y_dir", "z": "filter_z_dir"}


def filter_overrides(task: TaskConfig, point: dict[str, Any]) -> dict[str, Any]:
    """A point's overrides, plus clearing whatever filter it replaces on the same EE axis.

    A sweep axis over ``pick.approach_filter`` must replace the task's own filter on that
    robot's approach axis (``filter_z_dir`` on fr3, ``filter_x_dir`` on lift2, ...), and an
    axis over ``pick.filter_z_dir`` replaces a neutral filter that lands on z. Without this, a
    robot-neutral sweep over reference-form task files would set the same axis twice.
    """
    neutral = {"pick.approach_filter": "approach_filter", "pick.facing_filter": "facing_filter"}
    swept = [
        key for key in point if key in neutral or key.removeprefix("pick.") in FILTER_KEYS.values()
    ]
    if not swept:
        return point
    convention = reference_convention(task.robot)  # robot.yaml read once per process
    axis_of = {"approach_filter": convention.approach_axis, "facing_filter": convention.facing_axis}
    cleared: dict[str, Any] = {}
    for key in swept:
        if key in neutral:
            cleared[f"pick.{FILTER_KEYS[axis_of[neutral[key]]]}"] = None
        else:
            axis = key.removeprefix("pick.")[len("filter_")]
            for name, neutral_axis in axis_of.items():
                if neutral_axis == axis:
                    cleared[f"pick.{name}"] = None
    cleared = {k: v for k, v in cleared.items() if k not in point}
    return {**cleared, **point}


def object_overrides(task: TaskConfig, point: dict[str, Any]) -> dict[str, Any]:
    """Swapping the target object's mesh also renames the object after the mesh.

    A sweep axis ``object.mesh: [cube, banana]`` (``object.`` is the picked object, wherever it
    is in ``objects``) then reports ``object = banana`` in its rows (and ``pick.objects``
    follows), unless the point names the object itself. ``objects.0.mesh`` does the same only
    when ``objects[0]`` is the picked object.
    """
    target = task.target_object
    index = next(i for i, obj in enumerate(task.objects) if obj.name == target.name)
    if "object.mesh" in point:
        mesh = point["object.mesh"]
    elif "objects.0.mesh" in point and index == 0:
        mesh = point["objects.0.mesh"]
    else:
        return {}
    if any(k in point for k in ("object.name", f"objects.{index}.name")):
        return {}
    name = Path(str(mesh)).stem if Path(str(mesh)).suffix else str(mesh)
    if name == target.name:
        return {}
    if name in {obj.name for obj in task.objects}:
        raise ConfigError(f"object mesh {mesh!r} would rename the target to an existing name")
    picked = [name if n == target.name else n for n in (task.pick.objects or [target.name])]
    return {f"objects.{index}.name": name, "pick.objects": picked}


def point_overrides(task: TaskConfig, point: dict[str, Any]) -> dict[str, Any]:
    """Everything a point changes in a task: its own keys plus the implied ones."""
    implied = {**filter_overrides(task, point), **object_overrides(task, point)}
    return {**implied, **point}


def check_filters(task: TaskConfig, conventions: dict[str, Any] | None = None) -> None:
    """Resolve the task's filters for its robot now, so clashes fail at expansion.

    ``conventions`` keeps each robot's gripper convention across the points of one expansion
    (loading the robot reads its robot.yaml and URDF: ~40 ms, once per point before)."""
    from harness.grasps import resolve_filters
    from harness.robots import RobotModel

    memo = {} if conventions is None else conventions
    try:
        convention = memo.get(str(task.robot))
        if convention is None:
            convention = memo[str(task.robot)] = RobotModel.load(task.robot).convention
        resolve_filters(task.pick, convention)
    except ConfigError as exc:
        raise ConfigError(exc.message, key=f"pick.{exc.key}" if exc.key else "pick") from None


def refuse_key_spelled_twice(
    task: TaskConfig, point: dict[str, Any], sweep_path: Path | None
) -> None:
    """``ConfigError`` when two axes name one task key (``object.friction`` and
    ``objects.0.friction``, ``robot.gripper.force_limit`` and ``gripper.force_limit``): one
    would silently overwrite the other in every point."""
    from harness.config.overrides import target_index
    from harness.config.sweep import canonical_key

    target = target_index(task.model_dump(mode="json"))
    named: dict[str, str] = {}
    for key in point:
        first = named.setdefault(canonical_key(key, target), key)
        if first != key:
            raise ConfigError(
                f"axes {first!r} and {key!r} name the same key of task {task.name!r}; keep one",
                file=sweep_path,
                key=f"axes.{key}",
            )


def refuse_spelling_duplicate(
    seen: dict[str, int],
    configured: TaskConfig,
    point_id: int,
    points: list[dict[str, Any]],
    sweep_path: Path | None,
) -> None:
    """``ConfigError`` when point ``point_id`` configures the task exactly as an earlier point.

    Points are compared after the typed config has normalised their values, so one value
    spelled two ways (friction ``1`` and ``1.0``, ``lift_th: "0.02"`` and ``0.02``,
    ``validity: on`` and ``true``, ``object.friction`` and ``objects.0.friction``) is one
    point: run twice it would spend the episodes twice and mix two labels of one setting.
    """
    identity = configured.model_dump_json()
    first = seen.setdefault(identity, point_id)
    if first != point_id:
        raise ConfigError(
            f"point {point_id} {points[point_id]} is point {first} {points[first]} spelled "
            f"another way (the same task once the values are read); list each setting once",
            file=sweep_path,
            key="axes",
        )


def select_samples(episodes: list[EpisodeSpec], count: int) -> set[str]:
    """A deterministic sample of ``count`` episode ids (lowest id hashes)."""
    ranked = sorted(episodes, key=lambda e: hashlib.sha1(e.resolved_id.encode()).hexdigest())
    return {e.resolved_id for e in ranked[:count]}


def expand(
    sweep: SweepConfig,
    sweep_path: Path | None,
    tasks: list[TaskConfig] | None = None,
    progress: bool = False,
) -> list[EpisodeSpec]:
    """All episodes of the sweep, in a deterministic order (task, point, episode).

    ``tasks`` are the sweep's resolved tasks when the caller has already loaded them. With
    ``progress``, a large expansion (~15 ms per point) says how far it is on stderr.
    """
    if tasks is None:
        tasks = load_sweep_tasks(sweep, sweep_path)
    points = sweep_points(sweep)
    episodes: list[EpisodeSpec] = []
    report = ExpansionProgress(len(tasks) * len(points), enabled=progress)
    conventions: dict[str, Any] = {}
    for task in tasks:
        refuse_key_spelled_twice(task, points[0], sweep_path)
        seen: dict[str, int] = {}
        for point_id, point in enumerate(points):
            report.advance()
            try:
                configured = apply_overrides(task, point_overrides(task, point))
                check_filters(configured, conventions)
            except ConfigError as exc:
                raise ConfigError(
                    f"point {point_id} {point} does not apply to task {task.name!r}: {exc.message}",
                    file=sweep_path,
                    key=f"axes.{exc.key}" if exc.key else "axes",
                ) from None
            refuse_spelling_duplicate(seen, configured, point_id, points, sweep_path)
            for index in range(sweep.episodes_per_point):
                eid = episode_id(task.name, point, index)
                episodes.append(
                    EpisodeSpec(
                        episode_id=eid,
                        task=configured,
                        task_name=task.name,
                        point_id=point_id,
                        point=point,
                        episode_index=index,
                        seed=episode_seed(sweep.seed, index),
                        run=sweep.name,
                    )
                )
    report.done()
    ids = {e.resolved_id for e in episodes}
    if len(ids) != len(episodes):  # a row per id: a repeated id would silently drop rows
        raise ConfigError(
            f"{len(episodes) - len(ids)} episode(s) repeat another's id (identical points)",
            file=sweep_path,
            key="axes",
        )
    if sweep.record.startswith("sample:"):
        chosen = select_samples(episodes, int(sweep.record.split(":")[1]))
        episodes = [dataclasses.replace(e, record=e.resolved_id in chosen) for e in episodes]
    elif sweep.record == "all":
        episodes = [dataclasses.replace(e, record=True) for e in episodes]
    return episodes


class ExpansionProgress:
    """``expanding: i/N points`` on stderr every ``EVERY_S`` seconds, for expansions of at least
    ``MIN_POINTS`` points (a 300 x 300 grid took minutes with no output)."""

    MIN_POINTS = 1000
    EVERY_S = 2.0

    def __init__(self, total: int, enabled: bool = True) -> None:
        self.total = total
        self.enabled = enabled and total >= self.MIN_POINTS
        self.count = 0
        self.last = time.perf_counter()
        if self.enabled:
            print(f"expanding {total:,} points ...", file=sys.stderr, flush=True)

    def advance(self) -> None:
        self.count += 1
        if self.enabled and time.perf_counter() - self.last >= self.EVERY_S:
            self.last = time.perf_counter()
            print(f"expanding: {self.count:,}/{self.total:,} points", file=sys.stderr, flush=True)

    def done(self) -> None:
        if self.enabled:
            print(f"expanded {self.total:,} points", file=sys.stderr, flush=True)
