"""Scene: a robot, a table and the task's objects in one MuJoCo model; reset and placement.

World frame: origin at the table-top centre, z up; the table top is the plane z = 0.

The model is composed once per (robot, objects, physics) (``harness.sim.composition``); the
robot root body is a **mocap** body, so an episode moves the whole robot by writing
``data.mocap_pos / mocap_quat`` -- the model is never recompiled between episodes, and a
reset is ``mj_resetData`` plus a few array writes (the cheapest correct way: no recompilation,
no per-episode allocation). MuJoCo never collides two world-fixed or mocap-held bodies, so the
robot's static parts standing in the table cost nothing.

Contact switch: see ``harness.sim.masks``.

A second model, ``check_model`` (a copy with robot-table contact always on), serves the motion
planner's collision queries on its own ``MjData``.

Randomness: :meth:`Scene.reset` draws everything from the one ``numpy.random.Generator`` it is
given, in a fixed order (robot root, object placement, object orientation, home noise).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from harness.config import ObjectConfig, PhysicsConfig, Placement, TaskConfig
from harness.errors import HarnessError
from harness.objects.assets import ObjectAsset
from harness.robots.model import RobotModel
from harness.sim.budget import check_deadline, spend
from harness.sim.composition import TABLE_NAME, compose, object_configs
from harness.sim.index import (
    ArmHandles,
    SceneObject,
    body_subtree,
    find_body,
    index_arms,
    index_joints,
    index_objects,
    make_check_model,
    robot_joint_addresses,
)
from harness.sim.queries import SceneQueries
from harness.transforms import euler_xyz_deg_to_matrix, make_T, matrix_to_quat, quat_to_matrix

# Physics steps per mj_step call between deadline checks (~10-50 ms of a robot scene).
STEP_CHUNK = 500

MAX_SANE_SPEED = 1e3  # rad/s or m/s; anything faster is a diverged integration
# Scene bounds (world frame, origin at the table-top centre): an object beyond them has tunnelled
# through the table or been launched, and the episode is ``sim_unstable``, not a quiet
# ``no_contact``. Chosen, no public source: the table is ~1 m high and ~1-2 m wide, so both are
# far outside anything a pick reaches.
MAX_FALL_M = 2.0
MAX_REACH_M = 10.0
DROP_CLEARANCE = 0.001  # objects start this far above the table (the reference's 1 mm)
# Draws of an object with min_distance before it keeps the last one (chosen; the reference
# tries 1000 polygon placements, core/utils/visual_distractor.py find_polygon_placement).
MAX_PLACEMENT_DRAWS = 100


def yaw_quat(yaw_rad: float) -> np.ndarray:
    return np.array([math.cos(yaw_rad / 2.0), 0.0, 0.0, math.sin(yaw_rad / 2.0)])


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
class Scene(SceneQueries):
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
    def for_task(cls, task: TaskConfig) -> Scene:
        """The scene of ``task``: its robot and gripper, its objects, its physics."""
        robot = RobotModel.load(task.robot, task.gripper)
        return cls.build(robot, task.objects, task.physics, task.base_dir())

    @classmethod
    def build(
        cls,
        robot: RobotModel | str,
        objects: Sequence[ObjectConfig],
        physics: PhysicsConfig,
        base_dir: Path | str = ".",
    ) -> Scene:
        """Compose and compile the scene (robot, table, objects) with the physics options."""
        robot_model = robot if isinstance(robot, RobotModel) else RobotModel.load(robot)
        composition = compose(robot_model, objects, physics, base_dir)
        model = composition.model
        data = mujoco.MjData(model)
        return cls._index(
            robot_model,
            physics,
            composition.objects,
            composition.assets,
            model,
            data,
            composition.root_name,
        )

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
        root = find_body(model, robot, root_name)
        robot_bodies = set(body_subtree(model, root))
        robot_geom = np.array([int(b) in robot_bodies for b in model.geom_bodyid])
        root_weld = int(model.body_weldid[root])
        static_robot_geom = robot_geom & (model.body_weldid[model.geom_bodyid] == root_weld)

        joint_qpos, joint_dof = index_joints(model)
        robot_dof, robot_qpos = robot_joint_addresses(model, robot_bodies)
        actuator_ids = {model.actuator(a).name: a for a in range(model.nu)}
        scene_objects, geom_object = index_objects(model, robot, objects, assets)
        names = tuple(obj.name for obj in objects)
        arms = index_arms(model, robot, joint_qpos, joint_dof, actuator_ids)
        check_model = make_check_model(model, robot_geom)
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
        configs = object_configs(task)
        footprints: list[tuple[np.ndarray, float]] = []  # (xy, radius) of the objects placed
        for obj in self.objects.values():
            # The task's placement and orientations (the scene may have been built for another
            # task with the same objects), falling back to the scene's own.
            config = configs.get(obj.name, obj.config)
            region = config.placement or arm.object_region
            for _attempt in range(MAX_PLACEMENT_DRAWS if config.min_distance is not None else 1):
                pos, yaw = sample_placement(region, rng)
                R_base = np.eye(3)
                if config.orientations:
                    index = int(rng.integers(len(config.orientations)))
                    R_base = euler_xyz_deg_to_matrix(config.orientations[index])
                    if obj.name == task.target_object.name:
                        choice = index
                R = quat_to_matrix(yaw_quat(yaw)) @ R_base
                radius = float(np.max(np.linalg.norm((obj.asset.vertices @ R.T)[:, :2], axis=1)))
                if config.min_distance is None or all(
                    np.linalg.norm(pos[:2] - xy) - radius - r >= config.min_distance
                    for xy, r in footprints
                ):
                    break
            footprints.append((pos[:2].copy(), radius))
            lowest = float(np.min(obj.asset.vertices @ R[2, :]))
            pos = pos.copy()
            pos[2] += -lowest + DROP_CLEARANCE
            if obj.fixed:
                d.mocap_pos[obj.mocap_id] = pos
                d.mocap_quat[obj.mocap_id] = matrix_to_quat(R)
            else:
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
        """Advance the physics ``nstep`` steps, within the episode's step budget and wall-clock
        limit (``harness.sim.budget``): the budget is taken before the first step, the deadline
        checked every ``STEP_CHUNK`` steps (one ``mj_step`` call of 200k settle steps could not
        be interrupted: a 4 s limit gave a 32 s episode). Same states as one call."""
        spend(nstep)
        done = 0
        while done < nstep:
            if done:
                check_deadline()
            chunk = min(STEP_CHUNK, nstep - done)
            mujoco.mj_step(self.model, self.data, chunk)
            done += chunk

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
        return self._escaped()

    def _escaped(self) -> str | None:
        """A reason when an object has left the scene: more than ``MAX_FALL_M`` below the table
        top or beyond ``MAX_REACH_M`` of its centre (a tunnelled or launched object, not a
        pick that merely missed)."""
        for name, obj in self.objects.items():
            if obj.fixed:  # a fixture stays where it was placed (beside the table, maybe low)
                continue
            x, y, z = (float(v) for v in self.data.qpos[obj.qpos_adr : obj.qpos_adr + 3])
            if z < -MAX_FALL_M:
                return f"object {name!r} fell {-z:.3g} m below the table top: it left the scene"
            if max(abs(x), abs(y), z) > MAX_REACH_M:
                return f"object {name!r} left the scene at ({x:.3g}, {y:.3g}, {z:.3g}) m"
        return None


def sample_placement(placement: Placement, rng: np.random.Generator) -> tuple[np.ndarray, float]:
    """Position U(pos_range) (world, m) and yaw U(yaw_range) (rad)."""
    lo, hi = (np.asarray(v, dtype=float) for v in placement.pos_range)
    pos = lo + (hi - lo) * rng.random(3)
    yaw_lo, yaw_hi = placement.yaw_range
    yaw = math.radians(yaw_lo + (yaw_hi - yaw_lo) * rng.random())
    return pos, yaw
