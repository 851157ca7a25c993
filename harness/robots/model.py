"""RobotModel: one robot described by ``robots/<name>/robot.yaml`` + its URDF.

The URDF holds the kinematics (joint origins, axes, position limits) and the geometry; the yaml
holds everything the pick pipeline needs on top: the arms (joints, arm-base / EE / TCP frames,
finger joints and links, widths), the grasp convention (``R_ee_graspnet``, approach / facing
axes, ``tcp_offset``), home and home noise, placement ranges, per-joint timing limits and
actuator gains. Loading validates the yaml (unknown keys rejected) and then checks it against
the URDF: every named joint and frame exists, list lengths match, home is within the limits,
timing and force limits do not exceed the URDF's. Every problem is one located error,
``robot.yaml:line key.path: message``.

World convention used by the placement ranges: origin at the table-top centre, z up; robots
stand at -y and face +y (yaw 90 deg). Each arm's ``base_frame`` has x forward (towards the
table), z up, y left: the planning and grasp-filter frame.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from harness.config import Placement, read_yaml, validate_model
from harness.config.robot_registry import resolve_robot_yaml
from harness.config.task import GripperChoice
from harness.errors import HarnessError, InputFileError
from harness.grasps import GripperConvention
from harness.robots.facts import gripper_convention
from harness.robots.gripper import resolve_arm, variant_name
from harness.robots.spec import ArmSpec, LiftSpec, RobotFile
from harness.robots.urdf import UrdfInfo, UrdfJoint, read_urdf
from harness.robots.validation import check_against_urdf, check_interndata_block, located_error


@dataclass(frozen=True)
class JointDynamics:
    """Everything about one actuated joint: limits, timing, servo gains, joint dynamics."""

    name: str
    lower: float
    upper: float
    velocity: float
    acceleration: float
    jerk: float
    kp: float
    kv: float
    force_limit: float
    damping: float
    armature: float
    frictionloss: float


class RobotModel:
    """A validated robot: URDF path, arms, grasp convention, limits, gains and defaults.

    Build it with :meth:`load`. Arms are ``left`` / ``right`` (fr3 has only ``left``).
    """

    def __init__(
        self,
        spec: RobotFile,
        yaml_path: Path,
        urdf: UrdfInfo,
        urdf_path: Path,
        gripper: GripperChoice | None = None,
    ) -> None:
        self.spec = spec
        self.yaml_path = yaml_path
        self.urdf_path = urdf_path
        self.urdf = urdf
        self.name = spec.name
        self.description = spec.description
        self.root_frame = spec.root_frame
        self.placement: Placement = spec.placement
        self.gripper_variant = variant_name(spec, gripper)
        self.arms: dict[str, ArmSpec] = {
            name: resolve_arm(spec, arm.model_copy(update={"name": name}), gripper)
            for name, arm in spec.arms.items()
        }
        self.convention: GripperConvention = gripper_convention(spec.convention)
        self.lift: LiftSpec | None = spec.lift
        self.lift_joint: str | None = spec.lift.joint if spec.lift else None
        self.lift_home: float | None = spec.lift.home if spec.lift else None
        self._dynamics = self._collect_dynamics()

    # ---- loading

    @classmethod
    def load(cls, name_or_path: str | Path, gripper: GripperChoice | None = None) -> RobotModel:
        """Load a bundled robot by name (``fr3``) or a robot.yaml path (or its folder), with the
        gripper variant and grip overrides of ``gripper`` (default: robot.yaml's gripper)."""
        yaml_path = resolve_robot_yaml(name_or_path)
        doc = read_yaml(yaml_path)
        spec = validate_model(RobotFile, doc.data, doc)
        urdf_path = (yaml_path.parent / spec.urdf).resolve()
        if not urdf_path.is_file():
            raise located_error(doc, ("urdf",), f"URDF file not found: {urdf_path}")
        urdf = read_urdf(urdf_path)
        check_against_urdf(spec, urdf, doc)
        check_interndata_block(spec, doc)
        return cls(spec, yaml_path, urdf, urdf_path, gripper)

    # ---- joints and limits

    @property
    def frames(self) -> tuple[str, ...]:
        """Every URDF link (frame) name."""
        return self.urdf.links

    @property
    def movable_joints(self) -> list[str]:
        """Every non-fixed URDF joint, in URDF order (arms, fingers, lift)."""
        return [j.name for j in self.urdf.joints.values() if j.kind != "fixed"]

    @property
    def actuated_joints(self) -> list[str]:
        """Joints with their own position servo: the lift (if any), then each arm's joints."""
        joints = [self.lift_joint] if self.lift_joint else []
        for arm in self.arms.values():
            joints += arm.joints
        return joints

    @property
    def collisions_path(self) -> Path:
        """The self-collision pairs file next to the URDF (placo's format)."""
        return self.urdf_path.parent / "collisions.json"

    def self_collision_pairs(self) -> frozenset[frozenset[str]]:
        """The robot's one list of self-collision pairs (``collisions.json``, link names).

        The MuJoCo model excludes every other pair of links (``build_robot_spec``), so the
        physics, the planner's collision checks and the execution check all count exactly
        these pairs (issue 55). A file that is not a list of two known link names is one
        error naming the file and the entry."""
        from harness.reading import read_json

        path = self.collisions_path
        data = read_json(path, what="self-collision pairs file")
        links = set(self.urdf.links)
        if not isinstance(data, list):
            raise InputFileError(path, "expected a list of [link, link] pairs")
        pairs = set()
        for index, entry in enumerate(data):
            if (
                not isinstance(entry, list)
                or len(entry) != 2
                or not all(isinstance(name, str) and name in links for name in entry)
            ):
                message = f"entry {index} {entry!r} is not a pair of URDF link names"
                raise InputFileError(path, message, key=str(index))
            pairs.add(frozenset(entry))
        return frozenset(pairs)

    def arm(self, name: str) -> ArmSpec:
        try:
            return self.arms[name]
        except KeyError:
            raise HarnessError(
                f"robot {self.name!r} has no arm {name!r}; arms: {', '.join(self.arms)}"
            ) from None

    def _urdf_joint(self, joint: str) -> UrdfJoint:
        try:
            return self.urdf.joints[joint]
        except KeyError:
            raise HarnessError(f"robot {self.name!r} has no joint {joint!r}") from None

    def joint_limits(self, joint: str) -> tuple[float, float]:
        """Position limits (lower, upper) from the URDF, for any movable joint."""
        j = self._urdf_joint(joint)
        return (j.lower, j.upper)

    def dynamics(self, joint: str) -> JointDynamics:
        """Limits, timing and gains of an actuated joint (arm joint or lift)."""
        try:
            return self._dynamics[joint]
        except KeyError:
            raise HarnessError(
                f"{joint!r} is not an actuated joint of {self.name!r}; "
                f"actuated: {', '.join(self._dynamics)}"
            ) from None

    def velocity_limit(self, joint: str) -> float:
        return self.dynamics(joint).velocity

    def acceleration_limit(self, joint: str) -> float:
        return self.dynamics(joint).acceleration

    def jerk_limit(self, joint: str) -> float:
        return self.dynamics(joint).jerk

    def velocity_limits(self, joints: Sequence[str]) -> np.ndarray:
        return np.array([self.velocity_limit(j) for j in joints])

    def acceleration_limits(self, joints: Sequence[str]) -> np.ndarray:
        return np.array([self.acceleration_limit(j) for j in joints])

    def jerk_limits(self, joints: Sequence[str]) -> np.ndarray:
        return np.array([self.jerk_limit(j) for j in joints])

    def position_limits(self, joints: Sequence[str]) -> np.ndarray:
        """(n, 2) array of (lower, upper)."""
        return np.array([self.joint_limits(j) for j in joints])

    def home_configuration(self) -> dict[str, float]:
        """Every movable joint at home: arm homes, lift home, fingers open."""
        q: dict[str, float] = {}
        if self.lift_joint is not None and self.lift_home is not None:
            q[self.lift_joint] = self.lift_home
        for arm in self.arms.values():
            q.update(zip(arm.joints, arm.home, strict=True))
            for finger in arm.finger_joints:
                q[finger] = arm.finger_open_position
        for joint in self.movable_joints:  # anything else (none in the bundled robots): 0
            q.setdefault(
                joint, min(max(0.0, self.joint_limits(joint)[0]), self.joint_limits(joint)[1])
            )
        return q

    def nominal_placement(self) -> tuple[np.ndarray, float]:
        """Root position (middle of the placement range) and yaw (rad)."""
        lo, hi = (np.asarray(v, dtype=float) for v in self.placement.pos_range)
        yaw_lo, yaw_hi = self.placement.yaw_range
        return (lo + hi) / 2.0, math.radians((yaw_lo + yaw_hi) / 2.0)

    def _collect_dynamics(self) -> dict[str, JointDynamics]:
        out: dict[str, JointDynamics] = {}
        if self.lift is not None:
            lift = self.lift
            lo, hi = self.joint_limits(lift.joint)
            out[lift.joint] = JointDynamics(
                lift.joint, lo, hi, lift.velocity, lift.acceleration, lift.jerk, lift.kp,
                lift.kv, lift.force_limit, lift.damping, lift.armature, 0.0,
            )  # fmt: skip
        for arm in self.arms.values():
            lim, act = arm.limits, arm.actuators
            for i, joint in enumerate(arm.joints):
                lo, hi = self.joint_limits(joint)
                out[joint] = JointDynamics(
                    joint, lo, hi, lim.velocity[i], lim.acceleration[i], lim.jerk[i], act.kp[i],
                    act.kv[i], act.force_limit[i], act.damping[i], act.armature[i],
                    act.frictionloss[i],
                )  # fmt: skip
        return out

    def __repr__(self) -> str:
        return (
            f"RobotModel({self.name!r}, arms={list(self.arms)}, gripper={self.gripper_variant!r}, "
            f"urdf={self.urdf_path.name})"
        )
