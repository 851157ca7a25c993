"""Scene composition: the robot's MjSpec plus the table and the task's objects, compiled once.

Composition (``Scene.build``, once per (robot, objects, physics)): the robot's MjSpec from
``harness.robots.mujoco_spec.build_robot_spec`` is the base; the table (a box whose top is z = 0)
and one free body per object (its convex collision pieces as mesh geoms, its own mass, inertia and
friction) are added, and the physics options set (timestep, integrator, elliptic cones, impratio,
noslip). The robot root body is made a **mocap** body: an episode moves the whole robot by
writing ``data.mocap_pos / mocap_quat`` -- the model is never recompiled between episodes.

:func:`scene_key` names the composition a task needs, so scenes can be cached and reused.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from harness.config import ObjectConfig, PhysicsConfig, TaskConfig
from harness.config.memo import per_task
from harness.errors import HarnessError
from harness.objects.assets import ObjectAsset, default_objects_dir, load_object_info, resolve_mesh
from harness.robots.model import RobotModel
from harness.robots.mujoco_spec import build_robot_spec, finger_pad_geoms
from harness.sim.friction import add_object_contact_pairs
from harness.sim.masks import ROBOT_BIT, TABLE_BIT

TABLE_NAME = "table"
TABLE_HALF_SIZE = (0.8, 0.6, 0.025)  # m; top at z = 0
OBJECT_CONDIM = 4  # sliding + torsional friction
OBJECT_FRICTION_SPIN_ROLL = (0.005, 0.0001)
INTEGRATORS = {
    "euler": mujoco.mjtIntegrator.mjINT_EULER,
    "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
    "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
    "rk4": mujoco.mjtIntegrator.mjINT_RK4,
}
CONES = {"elliptic": mujoco.mjtCone.mjCONE_ELLIPTIC, "pyramidal": mujoco.mjtCone.mjCONE_PYRAMIDAL}


@dataclass(frozen=True)
class Composition:
    """A compiled scene model and what the index tables are built from."""

    model: mujoco.MjModel
    objects: list[ObjectConfig]  # with their object.yaml defaults applied
    assets: dict[str, ObjectAsset]
    root_name: str  # the robot's root body (a mocap body)


def compose(
    robot_model: RobotModel,
    objects: Sequence[ObjectConfig],
    physics: PhysicsConfig,
    base_dir: Path | str = ".",
) -> Composition:
    """Compose and compile the scene (robot, table, objects) with the physics options."""
    spec = build_robot_spec(robot_model)
    _set_options(spec, physics)
    root = _make_root_mocap(spec, robot_model)
    _set_robot_masks(spec, physics)
    _add_table(spec)
    base = Path(base_dir)
    assets: dict[str, ObjectAsset] = {}
    object_geoms: list[str] = []
    objects = [with_object_defaults(obj) for obj in objects]
    for obj in objects:
        mesh_path = resolve_mesh(obj.mesh, base)
        grasps = obj.grasps
        if grasps and not Path(grasps).is_absolute() and (base / grasps).is_file():
            grasps = str(base / grasps)  # relative to the task file
        asset = ObjectAsset.load(mesh_path, obj.scale, grasps, mass=obj.mass, friction=obj.friction)
        assets[obj.name] = asset
        object_geoms.extend(_add_object(spec, obj.name, asset, obj.fixed))
    add_object_contact_pairs(spec, object_geoms, finger_pad_geoms(spec, robot_model), TABLE_NAME)
    try:
        model = spec.compile()
    except ValueError as exc:
        raise HarnessError(f"MuJoCo cannot compile the scene: {exc}") from None
    return Composition(model, objects, assets, root)


def _set_robot_masks(spec: mujoco.MjSpec, physics: PhysicsConfig) -> None:
    """Robot geoms: table bit only with table contact on."""
    for geom in spec.geoms:
        if geom.contype or geom.conaffinity:
            geom.contype = ROBOT_BIT if geom.contype else 0
            geom.conaffinity = ROBOT_BIT | (TABLE_BIT if physics.table_contact else 0)


def _add_table(spec: mujoco.MjSpec) -> None:
    """The table: a box whose top is the plane z = 0."""
    spec.worldbody.add_geom(
        name=TABLE_NAME,
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=list(TABLE_HALF_SIZE),
        pos=[0.0, 0.0, -TABLE_HALF_SIZE[2]],
        contype=TABLE_BIT,
        conaffinity=TABLE_BIT,
        friction=[1.0, 0.005, 0.0001],
        rgba=[0.6, 0.45, 0.3, 1.0],
    )


def _set_options(spec: mujoco.MjSpec, physics: PhysicsConfig) -> None:
    opt = spec.option
    opt.timestep = physics.timestep
    opt.integrator = INTEGRATORS[physics.integrator]
    opt.cone = CONES[physics.cone]
    opt.impratio = physics.impratio
    opt.noslip_iterations = physics.noslip_iterations
    opt.iterations = physics.solver_iterations
    opt.gravity = list(physics.gravity)


def _make_root_mocap(spec: mujoco.MjSpec, robot: RobotModel) -> str:
    """Make the robot's root body a mocap body so an episode can move the robot cheaply."""
    root = spec.body(robot.root_frame)
    if root is None:
        raise HarnessError(f"robot {robot.name!r}: MjSpec has no root body {robot.root_frame!r}")
    if root.parent is not None and root.parent.name not in ("world", ""):
        raise HarnessError(f"robot {robot.name!r}: root body must be a child of the world")
    if root.first_joint() is not None:
        raise HarnessError(f"robot {robot.name!r}: root body {robot.root_frame!r} has a joint")
    root.mocap = True
    return robot.root_frame


def _add_object(spec: mujoco.MjSpec, name: str, asset: ObjectAsset, fixed: bool) -> list[str]:
    """A free body with one mesh geom per convex piece and the asset's mass properties; returns
    the names of its geoms. A fixture (``fixed``) is a mocap body instead: static, placed per
    episode through ``data.mocap_pos`` like the robot root, as the reference's GeometryObject
    (an Isaac GeometryPrim: collision, no rigid body; core/objects/geometry_object.py)."""
    body = spec.worldbody.add_body(name=name)
    if fixed:
        body.mocap = True
    else:
        body.add_freejoint(name=f"{name}_free")
    body.mass = asset.mass
    body.ipos = np.asarray(asset.center_of_mass, dtype=float)
    inertia = np.asarray(asset.inertia, dtype=float)
    body.fullinertia = [
        inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2], inertia[1, 2]
    ]  # fmt: skip
    body.explicitinertial = True
    names: list[str] = []
    for index, (vertices, faces) in enumerate(asset.collision_pieces):
        mesh_name = f"{name}_piece{index}"
        spec.add_mesh(
            name=mesh_name,
            uservert=np.asarray(vertices, dtype=np.float32).reshape(-1).tolist(),
            userface=np.asarray(faces, dtype=np.int32).reshape(-1).tolist(),
        )
        body.add_geom(
            name=mesh_name,
            type=mujoco.mjtGeom.mjGEOM_MESH,
            meshname=mesh_name,
            contype=ROBOT_BIT | TABLE_BIT,
            conaffinity=ROBOT_BIT | TABLE_BIT,
            condim=OBJECT_CONDIM,
            friction=[asset.friction, *OBJECT_FRICTION_SPIN_ROLL],
            density=0.0,
            rgba=[0.9, 0.65, 0.15, 1.0],
        )
        names.append(mesh_name)
    return names


def with_object_defaults(obj: ObjectConfig) -> ObjectConfig:
    """A default object (``mesh: cube``) takes ``mass``, ``friction`` and ``orientations`` from
    its ``tasks/objects/<name>/object.yaml`` unless the task sets them."""
    name = obj.mesh
    if "/" in name or "\\" in name or not (default_objects_dir() / name).is_dir():
        return obj
    info = load_object_info(name)
    update: dict[str, object] = {}
    for key in ("mass", "friction", "orientations", "category"):
        # None is "not given" (a task that went through model_dump lists every key as set)
        if getattr(obj, key) is None and info.get(key) is not None:
            update[key] = info[key]
    if not update:
        return obj
    return ObjectConfig.model_validate({**obj.model_dump(), **update})


@per_task
def object_configs(task: TaskConfig) -> dict[str, ObjectConfig]:
    """The task's objects with their defaults (``with_object_defaults``) by name, made once per
    task: each reset reads them, and each default object costs a file lookup and a validation.
    Read-only: the dict is shared by every call for the task."""
    return {config.name: with_object_defaults(config) for config in task.objects}


@per_task
def scene_key(task: TaskConfig) -> str:
    """Cache key of the scene a task needs: the robot and its gripper (variant, grip physics),
    each object's resolved mesh file and physical properties, and the physics options (not
    placements: those are per episode)."""
    base = task.base_dir()
    objects = []
    for obj in map(with_object_defaults, task.objects):
        try:
            mesh = str(resolve_mesh(obj.mesh, base).resolve())
        except HarnessError:
            mesh = f"{base}/{obj.mesh}"  # unresolvable: Scene.build reports it
        grasps = obj.grasps
        if grasps and not Path(grasps).is_absolute():
            grasps = str((base / grasps).resolve()) if (base / grasps).exists() else grasps
        objects.append([obj.name, mesh, grasps, list(obj.scale), obj.mass, obj.friction, obj.fixed])
    robot = [task.robot, task.gripper.model_dump(mode="json")]
    return json.dumps([robot, objects, task.physics.model_dump(mode="json")], sort_keys=True)
