"""The robot.yaml schema: pydantic models of ``robots/<name>/robot.yaml``, unknown keys rejected.

Validating a yaml file against these models catches typos and shape errors (list lengths per
joint, proper rotation of the grasp convention) before anything touches the URDF; the checks
against the URDF itself live in ``harness.robots.validation``.
"""

from __future__ import annotations

from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from harness.config import FiniteFloat, Placement

Axis = Literal["x", "y", "z"]
NonNegative = Annotated[float, Field(ge=0.0, allow_inf_nan=False)]
Positive = Annotated[float, Field(gt=0.0, allow_inf_nan=False)]


class _Strict(BaseModel):
    """Base of the robot.yaml models: unknown keys are errors."""

    model_config = ConfigDict(extra="forbid")


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
    """The gripper of an arm: one position servo on finger 1 (finger 2 follows by an equality).

    ``ctrl`` is the per-finger opening in m. ``force_limit`` is the grasp force: the largest
    normal force each pad presses an object with (a datasheet's "grasping force"); the servo's
    own force range is twice that, because finger 1's servo squeezes against finger 2 held by
    the coupling (``harness.robots.mujoco_spec``).
    """

    kp: Positive
    kv: NonNegative
    force_limit: Positive = Field(description="Grasp force limit per pad (N).")
    damping: NonNegative = 0.0
    armature: NonNegative = 0.0
    frictionloss: NonNegative = 0.0
    speed: Positive = Field(description="Finger speed used to time open / close (m/s).")
    pad_friction: Positive = Field(
        default=1.0, description="Sliding friction of the finger collision geoms (pads)."
    )
    pad_torsion: NonNegative = Field(
        default=0.01,
        description="Torsional friction of the pads (m; MuJoCo condim 4): the torque a pad "
        "resists about its contact normal per newton of normal force. The bundled robots derive "
        "it from the pad face: (3 pi / 16) x pad_friction x half the face's narrower side "
        "(tests/contact_patch.py); 0.01 when a robot.yaml gives none.",
    )
    grasp: Literal["force", "position"] = Field(
        default="force",
        description="force: closing drives the fingers until each pad presses with "
        "force_limit, whatever the object's width (a force-controlled grasp: Franka Hand "
        "grasp(), the Piper and ARX SDKs' effort-limited close); position: the servo's "
        "target is the closed width, so it presses kp * w / 4 per pad on an object of width w.",
    )

    def squeeze_position(self, closed_position: float) -> float:
        """The servo target (per-finger opening, m) that closing ends at: the closed position,
        or under ``force`` below it by enough that the servo saturates at its force range
        (2 x force_limit) wherever the fingers stop, plus 1 mm."""
        if self.grasp == "position":
            return closed_position
        return closed_position - 2.0 * self.force_limit / self.kp - 1e-3


GRIPPER_FIELDS = ("kp", "kv", "force_limit", "damping", "armature", "frictionloss", "speed",
                  "pad_friction", "pad_torsion", "grasp")  # fmt: skip


class GripperVariant(_Strict):
    """An alternative gripper of the robot: the values that differ from the arms' blocks."""

    description: str = ""
    open_width: Positive | None = None
    closed_width: NonNegative | None = None
    kp: Positive | None = None
    kv: NonNegative | None = None
    force_limit: Positive | None = None
    damping: NonNegative | None = None
    armature: NonNegative | None = None
    frictionloss: NonNegative | None = None
    speed: Positive | None = None
    pad_friction: Positive | None = None
    pad_torsion: NonNegative | None = None
    grasp: Literal["force", "position"] | None = None


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

    @property
    def finger_squeeze_position(self) -> float:
        """The gripper servo's target when closing ends (``GripperActuator.squeeze_position``)."""
        return self.gripper.squeeze_position(self.finger_closed_position)


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


class InternDataSpec(_Strict):
    """How InternDataEngine task files name this robot, and the defaults they take from it."""

    robot_config_file: str = Field(
        min_length=1,
        description="Basename of the reference robot config a task's robots entry names.",
    )
    home: dict[str, list[FiniteFloat]] = Field(
        description="Arm home in that config, used when a task file sets no <arm>_joint_home."
    )


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
    interndata: InternDataSpec | None = None
    gripper_variant: str = Field(
        default="default", min_length=1, description="Name of the gripper the arms describe."
    )
    gripper_variants: dict[str, GripperVariant] = Field(
        default_factory=dict,
        description="Alternative grippers a task selects with robot.gripper.variant.",
    )
    sources: dict[str, str] = Field(
        default_factory=dict,
        description="Where each physical value comes from: a dotted key of this file "
        "(arms.*.<key> for every arm) or urdf.<fact> (a value of the generated URDF) -> its "
        "source and derivation; 'chosen, no public source ...' marks an unknown, and the text "
        "after ' | ' names the task key that sweeps it.",
    )

    @model_validator(mode="after")
    def _source_keys(self) -> RobotFile:
        """Every ``sources`` key names a value of this file (or a ``urdf.`` fact)."""
        for key in self.sources:
            if key.startswith("urdf."):
                continue
            arms = list(self.arms) if key.startswith("arms.*.") else [None]
            for arm in arms:
                path = key.replace("arms.*.", f"arms.{arm}.") if arm else key
                if not _has_path(self, path.split(".")):
                    raise ValueError(f"sources: {key!r} names no value of robot.yaml")
        return self

    def unsourced(self) -> dict[str, str]:
        """The ``sources`` entries without a primary source ('chosen ...'), key -> the task key
        that sweeps it ('' when none is named)."""
        return {
            key: text.split(" | ", 1)[1].strip() if " | " in text else ""
            for key, text in self.sources.items()
            if "chosen" in text.split(" | ", 1)[0]
        }

    @model_validator(mode="after")
    def _variant_names(self) -> RobotFile:
        if self.gripper_variant in self.gripper_variants:
            raise ValueError(
                f"gripper_variants repeats the default gripper {self.gripper_variant!r}"
            )
        return self

    @property
    def variant_names(self) -> list[str]:
        """The default gripper first, then the alternatives."""
        return [self.gripper_variant, *self.gripper_variants]


def _has_path(model: object, parts: list[str]) -> bool:
    """Whether ``model`` (a pydantic model, dicts inside) has the dotted field ``parts``."""
    node: object = model
    for part in parts:
        if isinstance(node, BaseModel) and part in type(node).model_fields:
            node = getattr(node, part)
        elif isinstance(node, dict) and part in node:
            node = node[part]
        else:
            return False
    return True
