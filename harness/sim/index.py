"""Index tables of a compiled scene: where each object, arm, joint and actuator lives in MuJoCo.

Built once per compiled model (``Scene._index``) so the per-step code reads and writes plain
array addresses instead of looking names up. Also builds ``check_model``, the planner's copy of
the model with robot-table contact always on.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from harness.config import ObjectConfig
from harness.errors import HarnessError
from harness.objects.assets import ObjectAsset
from harness.robots.model import RobotModel
from harness.sim.masks import TABLE_BIT, refresh_body_masks


@dataclass(frozen=True)
class SceneObject:
    """One free object in the scene and where its state lives in the MuJoCo arrays."""

    name: str
    config: ObjectConfig
    asset: ObjectAsset
    body_id: int
    qpos_adr: int  # 7 values: position, wxyz quaternion (-1: a fixture)
    dof_adr: int  # 6 values: linear (world), angular (local) (-1: a fixture)
    geom_ids: np.ndarray
    mocap_id: int = -1  # a fixture's mocap index (static body), -1 for a free object

    @property
    def fixed(self) -> bool:
        return self.mocap_id >= 0


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


def find_body(model: mujoco.MjModel, robot: RobotModel, name: str) -> int:
    """The body id of ``name``; a missing body is the robot's error."""
    bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
    if bid < 0:
        raise HarnessError(f"robot {robot.name!r}: no MuJoCo body {name!r}")
    return bid


def index_joints(model: mujoco.MjModel) -> tuple[dict[str, int], dict[str, int]]:
    """qpos and dof address of every joint, by name."""
    joint_qpos: dict[str, int] = {}
    joint_dof: dict[str, int] = {}
    for j in range(model.njnt):
        joint_qpos[model.joint(j).name] = int(model.jnt_qposadr[j])
        joint_dof[model.joint(j).name] = int(model.jnt_dofadr[j])
    return joint_qpos, joint_dof


def robot_joint_addresses(
    model: mujoco.MjModel, robot_bodies: set[int]
) -> tuple[np.ndarray, np.ndarray]:
    """dof and qpos addresses of every joint of the robot's bodies."""
    robot_joints = [j for j in range(model.njnt) if int(model.jnt_bodyid[j]) in robot_bodies]
    robot_dof = np.array([model.jnt_dofadr[j] for j in robot_joints], dtype=np.int64)
    robot_qpos = np.array([model.jnt_qposadr[j] for j in robot_joints], dtype=np.int64)
    return robot_dof, robot_qpos


def index_objects(
    model: mujoco.MjModel,
    robot: RobotModel,
    objects: Sequence[ObjectConfig],
    assets: dict[str, ObjectAsset],
) -> tuple[dict[str, SceneObject], np.ndarray]:
    """Each object's body, joint addresses and geoms, and the (ngeom,) geom -> object index."""
    scene_objects: dict[str, SceneObject] = {}
    geom_object = np.full(model.ngeom, -1, dtype=np.int64)
    for index, obj in enumerate(objects):
        bid = find_body(model, robot, obj.name)
        jid = int(model.body_jntadr[bid])
        geoms = np.flatnonzero(model.geom_bodyid == bid)
        geom_object[geoms] = index
        mocap = int(model.body_mocapid[bid])
        scene_objects[obj.name] = SceneObject(
            name=obj.name,
            config=obj,
            asset=assets[obj.name],
            body_id=bid,
            qpos_adr=int(model.jnt_qposadr[jid]) if jid >= 0 else -1,
            dof_adr=int(model.jnt_dofadr[jid]) if jid >= 0 else -1,
            geom_ids=geoms,
            mocap_id=mocap,
        )
    return scene_objects, geom_object


def index_arms(
    model: mujoco.MjModel,
    robot: RobotModel,
    joint_qpos: dict[str, int],
    joint_dof: dict[str, int],
    actuator_ids: dict[str, int],
) -> dict[str, ArmHandles]:
    """The MuJoCo addresses of each arm of the robot."""
    arms: dict[str, ArmHandles] = {}
    for name, arm in robot.arms.items():
        active = ([robot.lift_joint] if robot.lift_joint else []) + list(arm.joints)
        try:
            actuators = np.array([actuator_ids[j] for j in active])
            gripper = actuator_ids[f"{name}_gripper"]
        except KeyError as exc:
            raise HarnessError(f"robot {robot.name!r}: no actuator {exc}") from None
        left, right = (find_body(model, robot, b) for b in arm.finger_bodies)
        fingers = (left, right)
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
            base_body=find_body(model, robot, arm.base_frame),
            ee_body=find_body(model, robot, arm.ee_frame),
            tcp_body=find_body(model, robot, arm.tcp_frame),
            finger_bodies=fingers,
            finger_geom_side=side,
        )
    return arms


def make_check_model(model: mujoco.MjModel, robot_geom: np.ndarray) -> mujoco.MjModel:
    """A copy of the model with robot-table contact always on, for the planner's queries."""
    check_model = copy.copy(model)
    for g in np.flatnonzero(robot_geom):
        if check_model.geom_conaffinity[g] or check_model.geom_contype[g]:
            check_model.geom_conaffinity[g] |= TABLE_BIT
    refresh_body_masks(check_model)
    return check_model
