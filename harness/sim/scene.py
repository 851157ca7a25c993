"""Scene: a robot, a table and the task's objects in one MuJoCo model; reset, placement, queries.

World frame: origin at the table-top centre, z up; the table top is the plane z = 0.

Composition (``Scene.build``, once per (robot, objects, physics)): the robot's MjSpec from
``harness.robots.mujoco_spec.build_robot_spec`` is the base; the table (a box whose top is z = 0)
and one free body per object (its convex collision pieces as mesh geoms, its own mass, inertia and
friction) are added, and the physics options set (timestep, integrator, elliptic cones, impratio,
noslip). The robot root body is made a **mocap** body: an episode moves the whole robot by
writing ``data.mocap_pos / mocap_quat`` -- the model is never recompiled between episodes, and a
reset is ``mj_resetData`` plus a few array writes (the cheapest correct way: no recompilation,
no per-episode allocation). MuJoCo never collides two world-fixed or mocap-held bodies, so the
robot's static parts standing in the table cost nothing.

Contact switch: the table geom uses contype/conaffinity bit 1 (value 2); objects carry bits 0
and 1; robot geoms carry bit 1 only when ``physics.table_contact`` is on (the reference turns
robot-table contact off with ``neglect_collision_names: [table]``).

A second model, ``check_model`` (a copy with robot-table contact always on), serves the motion
planner's collision queries on its own ``MjData``.

Randomness: :meth:`Scene.reset` draws everything from the one ``numpy.random.Generator`` it is
given, in a fixed order (robot root, object placement, object orientation, home noise).
"""

from __future__ import annotations

import copy
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from harness.config import ObjectConfig, PhysicsConfig, Placement, TaskConfig
from harness.errors import HarnessError
from harness.objects.assets import ObjectAsset, default_objects_dir, load_object_info, resolve_mesh
from harness.robots.model import RobotModel
from harness.transforms import (
    euler_xyz_deg_to_matrix,
    invert_T,
    make_T,
    matrix_to_quat,
    quat_to_matrix,
)

TABLE_NAME = "table"
TABLE_HALF_SIZE = (0.8, 0.6, 0.025)  # m; top at z = 0
TABLE_BIT = 2  # contype / conaffinity bit of the table
ROBOT_BIT = 1
MAX_SANE_SPEED = 1e3  # rad/s or m/s; anything faster is a diverged integration
DROP_CLEARANCE = 0.001  # objects start this far above the table (the reference's 1 mm)
OBJECT_CONDIM = 4  # sliding + torsional friction
OBJECT_FRICTION_SPIN_ROLL = (0.005, 0.0001)
INTEGRATORS = {
    "euler": mujoco.mjtIntegrator.mjINT_EULER,
    "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
    "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
    "rk4": mujoco.mjtIntegrator.mjINT_RK4,
}
CONES = {"elliptic": mujoco.mjtCone.mjCONE_ELLIPTIC, "pyramidal": mujoco.mjtCone.mjCONE_PYRAMIDAL}


# --------------------------------------------------------------------------------------------
# Small pose helpers


def T_from_pos_mat(pos: np.ndarray, xmat: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = np.asarray(xmat).reshape(3, 3)
    T[:3, 3] = pos
    return T


def yaw_quat(yaw_rad: float) -> np.ndarray:
    return np.array([math.cos(yaw_rad / 2.0), 0.0, 0.0, math.sin(yaw_rad / 2.0)])


# --------------------------------------------------------------------------------------------
# Index tables


@dataclass(frozen=True)
class SceneObject:
    """One free object in the scene and where its state lives in the MuJoCo arrays."""

    name: str
    config: ObjectConfig
    asset: ObjectAsset
    body_id: int
    qpos_adr: int  # 7 values: position, wxyz quaternion
    dof_adr: int  # 6 values: linear (world), angular (local)
    geom_ids: np.ndarray


@dataclass(frozen=True)
class ArmHandles:
    """MuJoCo addresses of one arm. ``active_*`` = the lift (if any) followed by the arm joints:
    the joints the planner moves for this arm."""

    name: str
    joint_names: tuple[str, ...]
    active_names: tuple[str, ...]
    active_qpos: np.ndarray
    active_dof: np.ndarray
    active_actuators: np.ndarray
    arm_qpos: np.ndarray
    gripper_actuator: int
    finger_qpos: np.ndarray  # (2,)
    base_body: int
    ee_body: int
    tcp_body: int
    finger_bodies: tuple[int, int]
    finger_geom_side: np.ndarray  # (ngeom,) 0 left, 1 right, -1 not a finger geom of this arm


def body_subtree(model: mujoco.MjModel, root: int) -> list[int]:
    out = [root]
    for body in range(root + 1, model.nbody):
        parent = int(model.body_parentid[body])
        if parent in out:
            out.append(body)
    return out


# --------------------------------------------------------------------------------------------
# Reset result


@dataclass
class ResetState:
    """What a reset drew: robot root pose, object poses, the arm's home (with noise)."""

    T_world_root: np.ndarray
    T_world_objects: dict[str, np.ndarray]
    object_init_position: np.ndarray  # target object, before settling (reference obj_init_trans)
    home: dict[str, float]
    orientation_choice: int | None = None
    settle_steps: int = 0  # physics steps of the reset (init_record_time + settle_time)


# --------------------------------------------------------------------------------------------
# Scene


@dataclass
class Scene:
    """The compiled scene and its index tables. Build with :meth:`Scene.build`."""

    robot: RobotModel
    physics: PhysicsConfig
    objects: dict[str, SceneObject]
    model: mujoco.MjModel
    data: mujoco.MjData
    check_model: mujoco.MjModel
    root_body: int
    mocap_id: int
    arms: dict[str, ArmHandles]
    table_geom: int
    robot_geom: np.ndarray  # (ngeom,) bool
    static_robot_geom: np.ndarray  # (ngeom,) bool: robot geoms welded to the root
    geom_object: np.ndarray  # (ngeom,) object index in ``object_names`` or -1
    object_names: tuple[str, ...]
    joint_qpos: dict[str, int]
    joint_dof: dict[str, int]
    robot_dof: np.ndarray  # every robot joint's dof address
    robot_qpos: np.ndarray
    actuator_ids: dict[str, int]
    _tmp_force: np.ndarray = field(default_factory=lambda: np.zeros(6))

    # -- construction ---------------------------------------------------------------------------

    @classmethod
    def build(
        cls,
        robot: RobotModel | str,
        objects: Sequence[ObjectConfig],
        physics: PhysicsConfig,
        base_dir: Path | str = ".",
    ) -> Scene:
        """Compose and compile the scene (robot, table, objects) with the physics options."""
        from harness.robots.mujoco_spec import build_robot_spec

        robot_model = robot if isinstance(robot, RobotModel) else RobotModel.load(robot)
        spec = build_robot_spec(robot_model)
        _set_options(spec, physics)
        root = _make_root_mocap(spec, robot_model)

        # Robot geoms: table bit only with table contact on.
        for geom in spec.geoms:
            if geom.contype or geom.conaffinity:
                geom.contype = ROBOT_BIT if geom.contype else 0
                geom.conaffinity = ROBOT_BIT | (TABLE_BIT if physics.table_contact else 0)

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
        base = Path(base_dir)
        assets: dict[str, ObjectAsset] = {}
        objects = [with_object_defaults(obj) for obj in objects]
        for obj in objects:
            mesh_path = resolve_mesh(obj.mesh, base)
            grasps = obj.grasps
            if grasps and not Path(grasps).is_absolute() and (base / grasps).is_file():
                grasps = str(base / grasps)  # relative to the task file
            asset = ObjectAsset.load(
                mesh_path, obj.scale, grasps, mass=obj.mass, friction=obj.friction
            )
            assets[obj.name] = asset
            _add_object(spec, obj.name, asset)
        try:
            model = spec.compile()
        except ValueError as exc:
            raise HarnessError(f"MuJoCo cannot compile the scene: {exc}") from None
        data = mujoco.MjData(model)
        return cls._index(robot_model, physics, objects, assets, model, data, root)

    @classmethod
    def _index(
        cls,
        robot: RobotModel,
        physics: PhysicsConfig,
        objects: Sequence[ObjectConfig],
        assets: dict[str, ObjectAsset],
        model: mujoco.MjModel,
        data: mujoco.MjData,
        root_name: str,
    ) -> Scene:
        def body_id(name: str) -> int:
            bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
            if bid < 0:
                raise HarnessError(f"robot {robot.name!r}: no MuJoCo body {name!r}")
            return bid

        root = body_id(root_name)
        robot_bodies = set(body_subtree(model, root))
        robot_geom = np.array([int(b) in robot_bodies for b in model.geom_bodyid])
        root_weld = int(model.body_weldid[root])
        static_robot_geom = robot_geom & (model.body_weldid[model.geom_bodyid] == root_weld)

        joint_qpos: dict[str, int] = {}
        joint_dof: dict[str, int] = {}
        for j in range(model.njnt):
            joint_qpos[model.joint(j).name] = int(model.jnt_qposadr[j])
            joint_dof[model.joint(j).name] = int(model.jnt_dofadr[j])
        robot_joints = [j for j in range(model.njnt) if int(model.jnt_bodyid[j]) in robot_bodies]
        robot_dof = np.array([model.jnt_dofadr[j] for j in robot_joints], dtype=np.int64)
        robot_qpos = np.array([model.jnt_qposadr[j] for j in robot_joints], dtype=np.int64)
        actuator_ids = {model.actuator(a).name: a for a in range(model.nu)}

        scene_objects: dict[str, SceneObject] = {}
        geom_object = np.full(model.ngeom, -1, dtype=np.int64)
        names = tuple(obj.name for obj in objects)
        for index, obj in enumerate(objects):
            bid = body_id(obj.name)
            jid = int(model.body_jntadr[bid])
            geoms = np.flatnonzero(model.geom_bodyid == bid)
            geom_object[geoms] = index
            scene_objects[obj.name] = SceneObject(
                name=obj.name,
                config=obj,
                asset=assets[obj.name],
                body_id=bid,
                qpos_adr=int(model.jnt_qposadr[jid]),
                dof_adr=int(model.jnt_dofadr[jid]),
                geom_ids=geoms,
            )

        arms: dict[str, ArmHandles] = {}
        for name, arm in robot.arms.items():
            active = ([robot.lift_joint] if robot.lift_joint else []) + list(arm.joints)
            try:
                actuators = np.array([actuator_ids[j] for j in active])
                gripper = actuator_ids[f"{name}_gripper"]
            except KeyError as exc:
                raise HarnessError(f"robot {robot.name!r}: no actuator {exc}") from None
            fingers = tuple(body_id(b) for b in arm.finger_bodies)
            side = np.full(model.ngeom, -1, dtype=np.int64)
            for s, finger in enumerate(fingers):
                for b in body_subtree(model, finger):
                    side[model.geom_bodyid == b] = s
            arms[name] = ArmHandles(
                name=name,
                joint_names=tuple(arm.joints),
                active_names=tuple(active),
                active_qpos=np.array([joint_qpos[j] for j in active]),
                active_dof=np.array([joint_dof[j] for j in active]),
                active_actuators=actuators,
                arm_qpos=np.array([joint_qpos[j] for j in arm.joints]),
                gripper_actuator=gripper,
                finger_qpos=np.array([joint_qpos[j] for j in arm.finger_joints]),
                base_body=body_id(arm.base_frame),
                ee_body=body_id(arm.ee_frame),
                tcp_body=body_id(arm.tcp_frame),
                finger_bodies=fingers,  # type: ignore[arg-type]
                finger_geom_side=side,
            )

        check_model = copy.copy(model)
        for g in np.flatnonzero(robot_geom):
            if check_model.geom_conaffinity[g] or check_model.geom_contype[g]:
                check_model.geom_conaffinity[g] |= TABLE_BIT
        refresh_body_masks(check_model)
        table = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, TABLE_NAME)
        return cls(
            robot=robot,
            physics=physics,
            objects=scene_objects,
            model=model,
            data=data,
            check_model=check_model,
            root_body=root,
            mocap_id=int(model.body_mocapid[root]),
            arms=arms,
            table_geom=table,
            robot_geom=robot_geom,
            static_robot_geom=static_robot_geom,
            geom_object=geom_object,
            object_names=names,
            joint_qpos=joint_qpos,
            joint_dof=joint_dof,
            robot_dof=robot_dof,
            robot_qpos=robot_qpos,
            actuator_ids=actuator_ids,
        )

    # -- reset ----------------------------------------------------------------------------------

    def reset(
        self,
        task: TaskConfig,
        rng: np.random.Generator,
        settle_time: float = 0.1,
        init_record_time: float = 0.0,
    ) -> ResetState:
        """Start an episode: place the robot and objects, set home + noise, settle the objects.

        The target object's position is recorded (``object_init_position``, the reference's
        ``obj_init_trans``) after ``init_record_time`` seconds of physics, then the scene settles
        ``settle_time`` more seconds. The reference steps once (1/30 s) after placing, builds
        the skill (recording ``obj_init_trans``), then settles 20 steps.

        Draw order from ``rng``: robot root (position, yaw), then per object (position, yaw,
        orientation choice), then the arm's home noise.
        """
        m, d = self.model, self.data
        mujoco.mj_resetData(m, d)

        placement = task.robot_placement or self.robot.placement
        root_pos, root_yaw = sample_placement(placement, rng)
        d.mocap_pos[self.mocap_id] = root_pos
        d.mocap_quat[self.mocap_id] = yaw_quat(root_yaw)
        T_world_root = make_T(quat_to_matrix(yaw_quat(root_yaw)), root_pos)

        arm = self.robot.arm(task.arm)
        T_world_objects: dict[str, np.ndarray] = {}
        choice: int | None = None
        configs = {config.name: with_object_defaults(config) for config in task.objects}
        for obj in self.objects.values():
            # The task's placement and orientations (the scene may have been built for another
            # task with the same objects), falling back to the scene's own.
            config = configs.get(obj.name, obj.config)
            region = config.placement or arm.object_region
            pos, yaw = sample_placement(region, rng)
            R_base = np.eye(3)
            if config.orientations:
                index = int(rng.integers(len(config.orientations)))
                R_base = euler_xyz_deg_to_matrix(config.orientations[index])
                if obj.name == task.target_object.name:
                    choice = index
            R = quat_to_matrix(yaw_quat(yaw)) @ R_base
            lowest = float(np.min(obj.asset.vertices @ R[2, :]))
            pos = pos.copy()
            pos[2] += -lowest + DROP_CLEARANCE
            d.qpos[obj.qpos_adr : obj.qpos_adr + 3] = pos
            d.qpos[obj.qpos_adr + 3 : obj.qpos_adr + 7] = matrix_to_quat(R)
            T_world_objects[obj.name] = make_T(R, pos)

        home = self.home_configuration(task, rng)
        self.set_robot_configuration(home)
        mujoco.mj_forward(m, d)
        target = self.objects[task.target_object.name]
        settle_steps = 0
        if init_record_time > 0:
            settle_steps = max(1, round(init_record_time / m.opt.timestep))
            self.step(settle_steps)
        init_position = d.qpos[target.qpos_adr : target.qpos_adr + 3].copy()
        if settle_time > 0:
            steps = max(1, round(settle_time / m.opt.timestep))
            self.step(steps)
            settle_steps += steps
        if settle_steps:
            for obj in self.objects.values():
                T_world_objects[obj.name] = self.T_world_body(obj.body_id)
        return ResetState(T_world_root, T_world_objects, init_position, home, choice, settle_steps)

    def home_configuration(self, task: TaskConfig, rng: np.random.Generator) -> dict[str, float]:
        """Every robot joint's start value: homes (task overrides for the picking arm), Gaussian
        noise on the picking arm (std from the task or robot.yaml), clipped to the limits."""
        q = dict(self.robot.home_configuration())
        arm = self.robot.arm(task.arm)
        home = np.asarray(task.home if task.home is not None else arm.home, dtype=float)
        std = np.asarray(
            task.home_noise_std if task.home_noise_std is not None else arm.home_noise_std,
            dtype=float,
        )
        if home.shape != (len(arm.joints),) or std.shape != home.shape:
            raise HarnessError(
                f"task {task.name!r}: home / home_noise_std need {len(arm.joints)} values for "
                f"the {task.arm} arm of {self.robot.name}"
            )
        noisy = home + rng.normal(0.0, 1.0, size=home.shape) * std
        limits = self.robot.position_limits(arm.joints)
        noisy = np.clip(noisy, limits[:, 0], limits[:, 1])
        q.update(zip(arm.joints, noisy.tolist(), strict=True))
        return q

    def set_robot_configuration(self, q: dict[str, float]) -> None:
        """Write joint values and matching actuator targets (the robot holds still)."""
        d = self.data
        for name, value in q.items():
            d.qpos[self.joint_qpos[name]] = value
            actuator = self.actuator_ids.get(name)
            if actuator is not None:
                d.ctrl[actuator] = value
        for arm_name, handles in self.arms.items():
            d.ctrl[handles.gripper_actuator] = d.qpos[handles.finger_qpos[0]]
            del arm_name
        d.qvel[:] = 0.0

    # -- stepping -------------------------------------------------------------------------------

    def step(self, nstep: int) -> None:
        """Advance the physics ``nstep`` steps inside MuJoCo (one call)."""
        mujoco.mj_step(self.model, self.data, nstep)

    def unstable(self) -> str | None:
        """A reason string when the simulation has diverged (MuJoCo's bad-acceleration reset or a
        full contact / constraint buffer, NaN, or a joint speed beyond 1000), else None."""
        d = self.data
        bad = d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number
        if bad:
            return f"MuJoCo reported {bad} bad-acceleration warning(s) (the state was reset)"
        for kind in (mujoco.mjtWarning.mjWARN_CONTACTFULL, mujoco.mjtWarning.mjWARN_CNSTRFULL):
            if d.warning[kind].number:
                return f"MuJoCo warning {kind.name}"
        if not (np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel))):
            return "NaN in the simulation state"
        speed = float(np.max(np.abs(d.qvel))) if len(d.qvel) else 0.0
        if speed > MAX_SANE_SPEED:
            return f"a velocity of {speed:.3g} (rad or m)/s: the integration diverged"
        return None

    # -- state queries --------------------------------------------------------------------------

    def T_world_body(self, body: int) -> np.ndarray:
        d = self.data
        return T_from_pos_mat(d.xpos[body], d.xmat[body])

    def T_world_frame(self, name: str) -> np.ndarray:
        """World pose of a body (URDF link) or site, by name."""
        m = self.model
        bid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)
        if bid >= 0:
            return self.T_world_body(bid)
        sid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, name)
        if sid >= 0:
            return T_from_pos_mat(self.data.site_xpos[sid], self.data.site_xmat[sid])
        raise HarnessError(f"no body or site named {name!r} in the scene")

    def T_world_base(self, arm: str) -> np.ndarray:
        return self.T_world_body(self.arms[arm].base_body)

    def T_base_frame(self, arm: str, name: str) -> np.ndarray:
        """Pose of a frame in the arm base frame (the planning and filter frame)."""
        return invert_T(self.T_world_base(arm)) @ self.T_world_frame(name)

    def T_base_ee(self, arm: str) -> np.ndarray:
        handles = self.arms[arm]
        return invert_T(self.T_world_body(handles.base_body)) @ self.T_world_body(handles.ee_body)

    def T_world_root(self) -> np.ndarray:
        return self.T_world_body(self.root_body)

    def T_world_object(self, name: str) -> np.ndarray:
        return self.T_world_body(self.objects[name].body_id)

    def object_velocity(self, name: str) -> np.ndarray:
        """Linear (world, m/s) and angular velocity of an object, (6,)."""
        obj = self.objects[name]
        return self.data.qvel[obj.dof_adr : obj.dof_adr + 6].copy()

    def active_q(self, arm: str) -> np.ndarray:
        return self.data.qpos[self.arms[arm].active_qpos].copy()

    def gripper_opening(self, arm: str) -> float:
        """Mean per-finger opening (m); the gripper width is twice this."""
        return float(np.mean(self.data.qpos[self.arms[arm].finger_qpos]))

    def robot_joint_speed(self) -> float:
        """max |qvel| over every robot joint (rad/s or m/s)."""
        return float(np.max(np.abs(self.data.qvel[self.robot_dof]))) if len(self.robot_dof) else 0.0

    def finger_forces(self, arm: str, object_name: str) -> tuple[float, float]:
        """Summed contact normal force (N) between each finger of ``arm`` and the object."""
        d, m = self.data, self.model
        ncon = d.ncon
        if ncon == 0:
            return 0.0, 0.0
        geoms = d.contact.geom[:ncon]
        side = self.arms[arm].finger_geom_side
        obj_index = self.object_names.index(object_name)
        obj = self.geom_object
        forces = [0.0, 0.0]
        g1, g2 = geoms[:, 0], geoms[:, 1]
        hits = np.flatnonzero(
            ((side[g1] >= 0) & (obj[g2] == obj_index)) | ((side[g2] >= 0) & (obj[g1] == obj_index))
        )
        f6 = self._tmp_force
        for i in hits:
            mujoco.mj_contactForce(m, d, int(i), f6)
            finger = side[g1[i]] if side[g1[i]] >= 0 else side[g2[i]]
            forces[int(finger)] += abs(float(f6[0]))
        return forces[0], forces[1]

    def robot_contacts(self, arm: str | None = None) -> list[tuple[str, str]]:
        """Contacts of the robot with the environment (table, objects) and with itself across
        arms, as (robot body, other body) name pairs; finger-object contacts of ``arm`` and
        contacts of the robot's static parts are left out."""
        return [
            (self.model.body(a).name, self.model.body(b).name)
            for a, b in self.robot_contact_bodies(arm)
        ]

    def robot_contact_bodies(self, arm: str | None = None) -> list[tuple[int, int]]:
        d, m = self.data, self.model
        ncon = d.ncon
        if ncon == 0:
            return []
        geoms = d.contact.geom[:ncon]
        g1, g2 = geoms[:, 0], geoms[:, 1]
        robot = self.robot_geom
        moving = robot & ~self.static_robot_geom
        involved = (moving[g1] | moving[g2]) & ~(robot[g1] & robot[g2] & ~self._cross_arm(g1, g2))
        if arm is not None:
            side = self.arms[arm].finger_geom_side
            finger_object = ((side[g1] >= 0) & (self.geom_object[g2] >= 0)) | (
                (side[g2] >= 0) & (self.geom_object[g1] >= 0)
            )
            involved &= ~finger_object
        out = []
        for i in np.flatnonzero(involved):
            a, b = int(g1[i]), int(g2[i])
            if not robot[a]:
                a, b = b, a
            out.append((int(m.geom_bodyid[a]), int(m.geom_bodyid[b])))
        return out

    def _cross_arm(self, g1: np.ndarray, g2: np.ndarray) -> np.ndarray:
        """True where two robot geoms belong to different arms' subtrees."""
        owner = self.geom_arm
        return (owner[g1] >= 0) & (owner[g2] >= 0) & (owner[g1] != owner[g2])

    @property
    def geom_arm(self) -> np.ndarray:
        """(ngeom,) index of the arm (in ``arms`` order) whose subtree holds each geom, or -1."""
        cached = getattr(self, "_geom_arm_cache", None)
        if cached is None:
            cached = np.full(self.model.ngeom, -1, dtype=np.int64)
            for index, handles in enumerate(self.arms.values()):
                for body in body_subtree(self.model, handles.base_body):
                    cached[self.model.geom_bodyid == body] = index
            self._geom_arm_cache = cached
        return cached


# --------------------------------------------------------------------------------------------
# Composition helpers


def refresh_body_masks(model: mujoco.MjModel) -> None:
    """Recompute the per-body contype / conaffinity (the OR over each body's geoms) after
    changing geom masks at run time: MuJoCo's broad phase filters body pairs with them."""
    contype = np.zeros(model.nbody, dtype=np.int64)
    conaffinity = np.zeros(model.nbody, dtype=np.int64)
    np.bitwise_or.at(contype, model.geom_bodyid, model.geom_contype)
    np.bitwise_or.at(conaffinity, model.geom_bodyid, model.geom_conaffinity)
    model.body_contype[:] = contype
    model.body_conaffinity[:] = conaffinity


def sample_placement(placement: Placement, rng: np.random.Generator) -> tuple[np.ndarray, float]:
    """Position U(pos_range) (world, m) and yaw U(yaw_range) (rad)."""
    lo, hi = (np.asarray(v, dtype=float) for v in placement.pos_range)
    pos = lo + (hi - lo) * rng.random(3)
    yaw_lo, yaw_hi = placement.yaw_range
    yaw = math.radians(yaw_lo + (yaw_hi - yaw_lo) * rng.random())
    return pos, yaw


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


def _add_object(spec: mujoco.MjSpec, name: str, asset: ObjectAsset) -> None:
    """A free body with one mesh geom per convex piece and the asset's mass properties."""
    body = spec.worldbody.add_body(name=name)
    body.add_freejoint(name=f"{name}_free")
    body.mass = asset.mass
    body.ipos = np.asarray(asset.center_of_mass, dtype=float)
    inertia = np.asarray(asset.inertia, dtype=float)
    body.fullinertia = [
        inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2], inertia[1, 2]
    ]  # fmt: skip
    body.explicitinertial = True
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


def with_object_defaults(obj: ObjectConfig) -> ObjectConfig:
    """A default object (``mesh: cube``) takes ``mass``, ``friction`` and ``orientations`` from
    its ``tasks/objects/<name>/object.yaml`` unless the task sets them."""
    name = obj.mesh
    if "/" in name or "\\" in name or not (default_objects_dir() / name).is_dir():
        return obj
    info = load_object_info(name)
    update: dict[str, object] = {}
    for key in ("mass", "friction", "orientations", "category"):
        if key not in obj.model_fields_set and info.get(key) is not None:
            update[key] = info[key]
    if not update:
        return obj
    return ObjectConfig.model_validate({**obj.model_dump(), **update})


def scene_key(task: TaskConfig) -> str:
    """Cache key of the scene a task needs: the robot, each object's resolved mesh file and
    physical properties, and the physics options (not placements: those are per episode)."""
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
        objects.append([obj.name, mesh, grasps, list(obj.scale), obj.mass, obj.friction])
    return json.dumps([task.robot, objects, task.physics.model_dump(mode="json")], sort_keys=True)
