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
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from harness.config import ConfigError, FiniteFloat, Placement, read_yaml, validate_model
from harness.config.yamlio import KeyPath, YamlDocument, format_key_path
from harness.errors import HarnessError
from harness.grasps import GripperConvention

ROBOTS_DIR = Path(__file__).resolve().parents[2] / "robots"
"""Folder of the bundled robots: ``robots/<name>/robot.yaml``."""

Axis = Literal["x", "y", "z"]
NonNegative = Annotated[float, Field(ge=0.0, allow_inf_nan=False)]
Positive = Annotated[float, Field(gt=0.0, allow_inf_nan=False)]


class _Strict(BaseModel):
    """Base of the robot.yaml models: unknown keys are errors."""

    model_config = ConfigDict(extra="forbid")


# --------------------------------------------------------------------------------------------
# yaml schema


class ActuatorGains(_Strict):
    """MuJoCo position servo and joint dynamics, one list entry per joint (SI units)."""

    kp: list[Positive]
    kv: list[NonNegative]
    force_limit: list[Positive]
    damping: list[NonNegative]
    armature: list[NonNegative]
    frictionloss: list[NonNegative]


class TimingLimits(_Strict):
    """Limits used to time trajectories (rad or m per s, s^2, s^3), one entry per joint."""

    velocity: list[Positive]
    acceleration: list[Positive]
    jerk: list[Positive]


class GripperActuator(_Strict):
    """The one position servo driving both fingers (ctrl = per-finger opening in m)."""

    kp: Positive
    kv: NonNegative
    force_limit: Positive
    damping: NonNegative = 0.0
    armature: NonNegative = 0.0
    speed: Positive = Field(description="Finger speed used to time open / close (m/s).")


class ArmSpec(_Strict):
    """One arm: its joints, frames, gripper and defaults."""

    name: str = ""
    joints: list[str] = Field(min_length=1)
    base_frame: str
    ee_frame: str
    tcp_frame: str
    finger_joints: tuple[str, str]
    finger_bodies: tuple[str, str]
    open_width: Positive
    closed_width: NonNegative
    home: list[FiniteFloat]
    home_noise_std: list[NonNegative]
    object_region: Placement
    limits: TimingLimits
    actuators: ActuatorGains
    gripper: GripperActuator

    @model_validator(mode="after")
    def _lengths(self) -> ArmSpec:
        n = len(self.joints)
        lists = {
            "home": self.home,
            "home_noise_std": self.home_noise_std,
            **{f"limits.{k}": v for k, v in self.limits.model_dump().items()},
            **{f"actuators.{k}": v for k, v in self.actuators.model_dump().items()},
        }
        for key, values in lists.items():
            if len(values) != n:
                raise ValueError(f"{key} has {len(values)} entries for {n} joints")
        if len(set(self.joints)) != n:
            raise ValueError("joints must be distinct")
        if self.closed_width >= self.open_width:
            raise ValueError("closed_width must be below open_width")
        return self

    @property
    def finger_open_position(self) -> float:
        """Per-finger joint value of the open gripper (m)."""
        return self.open_width / 2.0

    @property
    def finger_closed_position(self) -> float:
        """Per-finger joint value of the closed gripper (m)."""
        return self.closed_width / 2.0


class LiftSpec(_Strict):
    """A prismatic lift carrying the arms (Lift-2)."""

    joint: str
    home: FiniteFloat
    velocity: Positive
    acceleration: Positive
    jerk: Positive
    kp: Positive
    kv: NonNegative
    force_limit: Positive
    damping: NonNegative = 0.0
    armature: NonNegative = 0.0


class ConventionSpec(_Strict):
    """Grasp convention: how GraspNet grasp axes map to the EE frame (reference robot yaml)."""

    R_ee_graspnet: tuple[
        tuple[FiniteFloat, FiniteFloat, FiniteFloat],
        tuple[FiniteFloat, FiniteFloat, FiniteFloat],
        tuple[FiniteFloat, FiniteFloat, FiniteFloat],
    ]
    ee_axis: Axis
    approach_axis: Axis
    facing_axis: Axis
    tcp_offset: Positive
    gripper_min_width: NonNegative
    gripper_max_width: Positive

    @model_validator(mode="after")
    def _consistent(self) -> ConventionSpec:
        if self.approach_axis != self.ee_axis:
            raise ValueError(
                f"approach_axis {self.approach_axis} must equal ee_axis {self.ee_axis}"
            )
        R = np.asarray(self.R_ee_graspnet, dtype=float)
        if not np.allclose(R @ R.T, np.eye(3), atol=1e-9) or np.linalg.det(R) < 0:
            raise ValueError("R_ee_graspnet must be a proper rotation")
        if self.facing_axis == self.ee_axis:
            raise ValueError("facing_axis must differ from ee_axis")
        if self.gripper_min_width >= self.gripper_max_width:
            raise ValueError("gripper_min_width must be below gripper_max_width")
        return self


class RobotFile(_Strict):
    """Top level of robot.yaml."""

    name: str = Field(min_length=1)
    description: str = ""
    urdf: str = Field(min_length=1, description="URDF path relative to this file.")
    root_frame: str
    placement: Placement = Field(description="Root pose in the world (table-top centre origin).")
    convention: ConventionSpec
    arms: dict[Literal["left", "right"], ArmSpec] = Field(min_length=1)
    lift: LiftSpec | None = None


# --------------------------------------------------------------------------------------------
# URDF facts


@dataclass(frozen=True)
class UrdfJoint:
    """A URDF joint as far as validation and the harness need it."""

    name: str
    kind: str
    parent: str
    child: str
    lower: float
    upper: float
    velocity: float
    effort: float


@dataclass(frozen=True)
class UrdfInfo:
    robot_name: str
    links: tuple[str, ...]
    joints: dict[str, UrdfJoint]
    root: str


def read_urdf(path: Path) -> UrdfInfo:
    """Parse link names and joints (type, limits) from a URDF; errors name the file."""
    try:
        root = ET.parse(path).getroot()
    except FileNotFoundError:
        raise ConfigError("URDF file not found", file=path) from None
    except (ET.ParseError, OSError) as exc:
        raise ConfigError(f"cannot read URDF: {exc}", file=path) from None
    links = tuple(link.get("name", "") for link in root.findall("link"))
    joints: dict[str, UrdfJoint] = {}
    for element in root.findall("joint"):
        limit = element.find("limit")
        attr = limit.attrib if limit is not None else {}
        name = element.get("name", "")
        parent = element.find("parent")
        child = element.find("child")
        joints[name] = UrdfJoint(
            name=name,
            kind=element.get("type", ""),
            parent=parent.get("link", "") if parent is not None else "",
            child=child.get("link", "") if child is not None else "",
            lower=float(attr.get("lower", "nan")),
            upper=float(attr.get("upper", "nan")),
            velocity=float(attr.get("velocity", "inf")),
            effort=float(attr.get("effort", "inf")),
        )
    children = {j.child for j in joints.values()}
    roots = [link for link in links if link not in children]
    if len(roots) != 1:
        raise ConfigError(f"URDF must have exactly one root link, found {roots}", file=path)
    return UrdfInfo(root.get("name", ""), links, joints, roots[0])


# --------------------------------------------------------------------------------------------
# The model


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

    def __init__(self, spec: RobotFile, yaml_path: Path, urdf: UrdfInfo, urdf_path: Path) -> None:
        self.spec = spec
        self.yaml_path = yaml_path
        self.urdf_path = urdf_path
        self.urdf = urdf
        self.name = spec.name
        self.description = spec.description
        self.root_frame = spec.root_frame
        self.placement: Placement = spec.placement
        self.arms: dict[str, ArmSpec] = {
            name: arm.model_copy(update={"name": name}) for name, arm in spec.arms.items()
        }
        c = spec.convention
        self.convention = GripperConvention(
            R_ee_graspnet=np.asarray(c.R_ee_graspnet, dtype=float),
            ee_axis=c.ee_axis,
            facing_axis=c.facing_axis,
            tcp_offset=c.tcp_offset,
            gripper_min_width=c.gripper_min_width,
            gripper_max_width=c.gripper_max_width,
        )
        self.lift: LiftSpec | None = spec.lift
        self.lift_joint: str | None = spec.lift.joint if spec.lift else None
        self.lift_home: float | None = spec.lift.home if spec.lift else None
        self._dynamics = self._collect_dynamics()

    # ---- loading

    @classmethod
    def load(cls, name_or_path: str | Path) -> RobotModel:
        """Load a bundled robot by name (``fr3``) or a robot.yaml path (or its folder)."""
        yaml_path = resolve_robot_yaml(name_or_path)
        doc = read_yaml(yaml_path)
        spec = validate_model(RobotFile, doc.data, doc)
        urdf_path = (yaml_path.parent / spec.urdf).resolve()
        if not urdf_path.is_file():
            raise _located(doc, ("urdf",), f"URDF file not found: {urdf_path}")
        urdf = read_urdf(urdf_path)
        _check_against_urdf(spec, urdf, doc)
        return cls(spec, yaml_path, urdf, urdf_path)

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
        """placo's self-collision pairs file next to the URDF."""
        return self.urdf_path.parent / "collisions.json"

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
        return f"RobotModel({self.name!r}, arms={list(self.arms)}, urdf={self.urdf_path.name})"


# --------------------------------------------------------------------------------------------
# Finding robots


def available_robots() -> list[str]:
    """Names of the bundled robots (folders of ``robots/`` holding a robot.yaml)."""
    if not ROBOTS_DIR.is_dir():
        return []
    return sorted(p.parent.name for p in ROBOTS_DIR.glob("*/robot.yaml"))


def resolve_robot_yaml(name_or_path: str | Path) -> Path:
    """A bundled robot name, a robot.yaml path or its folder -> the robot.yaml path."""
    text = str(name_or_path)
    candidate = Path(text).expanduser()
    looks_like_path = isinstance(name_or_path, Path) or "/" in text or text.endswith(".yaml")
    if candidate.is_dir() and (candidate / "robot.yaml").is_file():
        return (candidate / "robot.yaml").resolve()
    if candidate.is_file():
        return candidate.resolve()
    if looks_like_path:
        raise HarnessError(f"{text}: robot file not found (expected a robot.yaml or its folder)")
    bundled = ROBOTS_DIR / text / "robot.yaml"
    if bundled.is_file():
        return bundled
    raise HarnessError(
        f"unknown robot {text!r}; available robots: {', '.join(available_robots()) or 'none'}"
    )


# --------------------------------------------------------------------------------------------
# Validation against the URDF


def _located(doc: YamlDocument, key: KeyPath, message: str) -> ConfigError:
    return ConfigError(message, file=doc.path, line=doc.line_of(key), key=format_key_path(key))


def _check_against_urdf(spec: RobotFile, urdf: UrdfInfo, doc: YamlDocument) -> None:
    links = set(urdf.links)

    def need_link(key: KeyPath, name: str) -> None:
        if name not in links:
            raise _located(doc, key, f"frame {name!r} is not a link of the URDF")

    def need_joint(key: KeyPath, name: str, kinds: tuple[str, ...]) -> UrdfJoint:
        joint = urdf.joints.get(name)
        if joint is None:
            raise _located(doc, key, f"joint {name!r} is not in the URDF")
        if joint.kind not in kinds:
            raise _located(doc, key, f"joint {name!r} is {joint.kind}, expected {'/'.join(kinds)}")
        return joint

    if spec.root_frame != urdf.root:
        raise _located(doc, ("root_frame",), f"the URDF root link is {urdf.root!r}")
    used: dict[str, KeyPath] = {}
    for arm_name, arm in spec.arms.items():
        prefix: KeyPath = ("arms", arm_name)
        for field in ("base_frame", "ee_frame", "tcp_frame"):
            need_link((*prefix, field), getattr(arm, field))
        for i, body in enumerate(arm.finger_bodies):
            need_link((*prefix, "finger_bodies", i), body)
        for i, name in enumerate(arm.joints):
            key = (*prefix, "joints", i)
            if name in used:
                raise _located(
                    doc, key, f"joint {name!r} is already used at {format_key_path(used[name])}"
                )
            used[name] = key
            joint = need_joint(key, name, ("revolute", "prismatic", "continuous"))
            _check_joint_numbers(doc, prefix, i, joint, arm)
        for i, name in enumerate(arm.finger_joints):
            joint = need_joint((*prefix, "finger_joints", i), name, ("prismatic",))
            for key, width in (("open_width", arm.open_width), ("closed_width", arm.closed_width)):
                if not joint.lower - 1e-12 <= width / 2.0 <= joint.upper + 1e-12:
                    raise _located(
                        doc,
                        (*prefix, key),
                        f"{width} m needs {width / 2} m per finger, outside {name} limits "
                        f"[{joint.lower}, {joint.upper}]",
                    )
            if arm.gripper.speed > joint.velocity + 1e-12:
                raise _located(
                    doc,
                    (*prefix, "gripper", "speed"),
                    f"{arm.gripper.speed} m/s exceeds the URDF velocity {joint.velocity} of {name}",
                )
    if spec.lift is not None:
        joint = need_joint(("lift", "joint"), spec.lift.joint, ("prismatic",))
        if not joint.lower <= spec.lift.home <= joint.upper:
            raise _located(
                doc, ("lift", "home"), f"{spec.lift.home} is outside [{joint.lower}, {joint.upper}]"
            )
        if spec.lift.velocity > joint.velocity + 1e-12:
            raise _located(doc, ("lift", "velocity"), f"exceeds the URDF velocity {joint.velocity}")
        if spec.lift.force_limit > joint.effort + 1e-12:
            raise _located(doc, ("lift", "force_limit"), f"exceeds the URDF effort {joint.effort}")


def _check_joint_numbers(
    doc: YamlDocument, prefix: KeyPath, i: int, joint: UrdfJoint, arm: ArmSpec
) -> None:
    if (
        not (math.isfinite(joint.lower) and math.isfinite(joint.upper))
        or joint.lower >= joint.upper
    ):
        raise _located(
            doc, (*prefix, "joints", i), f"URDF limits of {joint.name} are not a finite range"
        )
    home = arm.home[i]
    if not joint.lower <= home <= joint.upper:
        raise _located(
            doc,
            (*prefix, "home", i),
            f"{home} is outside the {joint.name} limits [{joint.lower}, {joint.upper}]",
        )
    velocity = arm.limits.velocity[i]
    if velocity > joint.velocity + 1e-12:
        raise _located(
            doc,
            (*prefix, "limits", "velocity", i),
            f"{velocity} exceeds the URDF velocity {joint.velocity} of {joint.name}",
        )
    force = arm.actuators.force_limit[i]
    if force > joint.effort + 1e-12:
        raise _located(
            doc,
            (*prefix, "actuators", "force_limit", i),
            f"{force} exceeds the URDF effort {joint.effort} of {joint.name}",
        )
