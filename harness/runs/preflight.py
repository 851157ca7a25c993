"""Deep validation: everything a task needs to run, checked before any episode runs.

The YAML schema (``harness.config``) checks a file's shape; this checks what the run will load:
the robot is known and has the task's arm, ``home`` has one value per joint of that arm and lies
within the URDF's joint limits, every mesh exists, is not empty and loads (its collision pieces
too), the target's grasp file exists and holds a finite N x 17 float array (read with
``allow_pickle=False``), and no free object is placed wholly inside the table (below its top
with its whole footprint over it; objects beside the table, and fixtures, are accepted, with a
warning where the reference's placement may overlap the table). Without this, each of those
turns every row of a run into ``error`` (or, for the placement, into a quiet success that the
reference engine would never see). Every problem is one ``InputFileError`` line naming the file
and the key. ``harness validate`` runs it on task and sweep files, ``harness run`` and
``harness sweep`` before the first episode.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from harness.config import TaskConfig
from harness.errors import HarnessError, InputFileError

# Joint values within this of a URDF limit count as inside it (rounded homes in robot.yaml).
LIMIT_TOLERANCE_RAD = 1e-6
# An object's placement may dip this far below resting on the table (m) before it is refused.
TABLE_TOLERANCE_M = 0.001


def _where(task: TaskConfig) -> str:
    return task.source or f"task {task.name!r}"


def check_task(task: TaskConfig) -> list[str]:
    """Raise one ``HarnessError`` line for the first thing ``task`` would fail on at run time;
    return the warnings (lines) about what runs but may not be meant (``_placement_warnings``)."""
    from harness.robots import RobotModel

    where = _where(task)
    try:
        robot = RobotModel.load(task.robot, task.gripper)
    except HarnessError as exc:
        raise InputFileError(where, str(exc), "robot") from None
    try:
        arm = robot.arm(task.arm)
    except HarnessError as exc:
        raise InputFileError(where, str(exc), "arm") from None
    _check_home(task, robot, arm.joints, where)
    return _check_objects(task, where)


def _check_home(task: TaskConfig, robot: object, joints: list[str], where: str) -> None:
    from harness.robots import RobotModel

    assert isinstance(robot, RobotModel)
    for key, values in (("home", task.home), ("home_noise_std", task.home_noise_std)):
        if values is not None and len(values) != len(joints):
            raise InputFileError(
                where,
                f"has {len(values)} values; the {task.arm} arm of {robot.name} has "
                f"{len(joints)} joints ({', '.join(joints)})",
                key,
            )
    if task.home is None:
        return
    limits = robot.position_limits(joints)
    for index, (joint, value) in enumerate(zip(joints, task.home, strict=True)):
        lo, hi = limits[index]
        if not lo - LIMIT_TOLERANCE_RAD <= value <= hi + LIMIT_TOLERANCE_RAD:
            raise InputFileError(
                where,
                f"{value:g} is outside the limits of joint {joint} [{lo:g}, {hi:g}]",
                f"home[{index}]",
            )


def _placement_warnings(task: TaskConfig, index: int, radius: float, where: str) -> list[str]:
    """Objects rest on the table top at placement z offset 0. Below that, an object whose
    footprint (its placement xy range widened by the object's radius) misses the table stands
    beside it (the reference's bins on the floor: fine for a fixture; a free object falls, the
    harness has no floor); one whose footprint overlaps the table starts inside it. The
    reference places both as told, so that is a warning, except for a free object whose every
    placement lies over the table: it always starts inside the slab (refused)."""
    obj = task.objects[index]
    if obj.placement is None:
        return []
    (x_lo, y_lo, z_min), (x_hi, y_hi, _z_max) = obj.placement.pos_range
    if z_min >= -TABLE_TOLERANCE_M:
        return []
    from harness.sim.composition import TABLE_HALF_SIZE

    half_x, half_y = TABLE_HALF_SIZE[0], TABLE_HALF_SIZE[1]
    key = f"objects[{index}].placement.pos_range"
    depth = f"{-z_min * 1000:.0f} mm"
    overlaps = x_lo - radius < half_x and x_hi + radius > -half_x
    overlaps = overlaps and y_lo - radius < half_y and y_hi + radius > -half_y
    inside = -half_x <= x_lo and x_hi <= half_x and -half_y <= y_lo and y_hi <= half_y
    if not overlaps:
        if obj.fixed:
            return []
        return [
            f"warning: {where}: {key}: object {obj.name!r} is placed beside the table, {depth} "
            "below its top; the harness has no floor, so a free object there falls (make it a "
            "fixture: fixed: true)"
        ]
    if inside and not obj.fixed:
        raise InputFileError(
            where,
            f"z offset {z_min:g} m places object {obj.name!r} {depth} inside the table (z "
            "offsets are above resting on the table top; use >= 0)",
            key,
        )
    return [
        f"warning: {where}: {key}: object {obj.name!r} may start up to {depth} inside the "
        "table where its footprint overlaps the table top (the reference places it so too; "
        f"its arena's table may be smaller than the harness's {2 * half_x:.2f} x "
        f"{2 * half_y:.2f} m)"
    ]


def _check_objects(task: TaskConfig, where: str) -> list[str]:
    from harness.grasps import load_grasp_file
    from harness.objects.assets import ObjectAsset, find_grasp_file, resolve_mesh
    from harness.sim.composition import with_object_defaults

    base = task.base_dir()
    warnings: list[str] = []
    for index, raw in enumerate(task.objects):
        obj = with_object_defaults(raw)
        key = f"objects[{index}]"
        try:
            mesh_path = resolve_mesh(obj.mesh, base)
            grasps = obj.grasps
            if grasps is not None and not Path(grasps).is_absolute():
                grasps = str(base / grasps) if (base / grasps).is_file() else grasps
            asset = ObjectAsset.load(
                mesh_path, obj.scale, grasps, task.pick.npy_name, obj.mass, obj.friction
            )
        except InputFileError as exc:
            raise InputFileError(exc.file, exc.message, f"{key}.{exc.key or 'mesh'}") from None
        except HarnessError as exc:
            raise InputFileError(where, str(exc), f"{key}.mesh") from None
        radius = float(np.max(np.linalg.norm(asset.vertices, axis=1)))
        warnings.extend(_placement_warnings(task, index, radius, where))
        if obj.name != task.target_object.name:
            continue
        grasp_path = asset.grasp_path
        if obj.grasps is None and task.pick.npy_name != "Aligned_grasp_sparse.npy":
            grasp_path = find_grasp_file(asset.path, task.pick.npy_name)
        if grasp_path is None:
            raise InputFileError(
                where,
                f"object {obj.name!r} ({mesh_path}) has no grasp file ({task.pick.npy_name}, "
                "<mesh>_grasps.npy or grasps.npy next to the mesh)",
                f"{key}.grasps",
            )
        try:
            load_grasp_file(grasp_path)
        except InputFileError as exc:
            where_in_file = f"{key}.grasps {exc.key or ''}".strip()
            raise InputFileError(exc.file, exc.message, where_in_file) from None
    return warnings


def check_tasks(tasks: list[TaskConfig]) -> list[str]:
    """``check_task`` on each distinct task; its warnings, each once, are printed to stderr and
    returned. Tasks that differ only in selection keys (the filters: a tune grid's points) are
    checked once: nothing ``check_task`` reads depends on them, and a check reads the robot's
    files and the objects' meshes (~70 ms a point)."""
    from harness.episode.candidate_cache import physics_key

    seen: set[str] = set()
    lines: list[str] = []
    for task in tasks:
        key = physics_key(task)
        if key not in seen:
            seen.add(key)
            lines.extend(line for line in check_task(task) if line not in lines)
    for line in lines:
        print(line, file=sys.stderr)
    return lines
