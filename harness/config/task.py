"""A task: one robot arm picking one object; its placements, objects and physics."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import Field, ValidationError, field_validator, model_validator

from harness.config.errors import KeyedValueError
from harness.config.handover import HandoverPrelude
from harness.config.messages import suggest
from harness.config.pick import PickConfig
from harness.config.values import FiniteFloat, StrictModel, Vec3

# Placements farther than this from the table-top centre are refused: Scene.unstable already
# calls an object 10 m out sim_unstable, so such a placement can only fail (x: 1e300 ran).
MAX_PLACEMENT_M = 10.0


class Placement(StrictModel):
    """Uniform placement: position = centre + U(pos_range), yaw = U(yaw_range) in degrees.

    Positions are in the world frame (origin at the table-top centre, z up). For objects the
    z offset is added on top of resting on the table.
    """

    pos_range: tuple[Vec3, Vec3]
    yaw_range: tuple[FiniteFloat, FiniteFloat] = (-180.0, 180.0)

    @model_validator(mode="after")
    def _ordered(self) -> Placement:
        lo, hi = self.pos_range
        for axis, (a, b) in enumerate(zip(lo, hi, strict=True)):
            if max(abs(a), abs(b)) > MAX_PLACEMENT_M:
                raise KeyedValueError(
                    "pos_range",
                    f"pos_range axis {'xyz'[axis]}: {max(a, b, key=abs):g} m is more than "
                    f"{MAX_PLACEMENT_M:g} m from the table centre (a scene object that far out "
                    "is sim_unstable at once)",
                )
            if a > b:
                raise KeyedValueError(
                    "pos_range", f"pos_range axis {'xyz'[axis]}: min {a} must be <= max {b}"
                )
        if self.yaw_range[0] > self.yaw_range[1]:
            raise KeyedValueError(
                "yaw_range", f"yaw_range min {self.yaw_range[0]} must be <= max {self.yaw_range[1]}"
            )
        return self


class ObjectConfig(StrictModel):
    """One object: a mesh (path, or the name of a default object), its grasps and physics."""

    name: str = Field(min_length=1)
    mesh: str = Field(min_length=1, description="Mesh path (relative to the YAML) or object name.")
    grasps: str | None = Field(default=None, description="Grasp file; default by naming rule.")
    scale: tuple[FiniteFloat, FiniteFloat, FiniteFloat] = (1.0, 1.0, 1.0)
    mass: FiniteFloat | None = Field(
        default=None,
        gt=0.0,
        le=100.0,
        description="kg. Default: the USD's physics:mass (UsdPhysics.MassAPI; 0.5 on every "
        "reference object), else 0.1 (chosen).",
    )
    friction: FiniteFloat | None = Field(
        default=None,
        gt=0.0,
        le=10.0,
        description="Default: the static friction of the USD's bound physics material (1.0 on "
        "every reference object), else 1.0 (MuJoCo's default).",
    )
    fixed: bool = Field(
        default=False,
        description="A fixture: a static body placed like the others that collides and never "
        "moves (the reference's GeometryObject, e.g. a bin). The picked object cannot be one.",
    )
    placement: Placement | None = Field(
        default=None, description="Default: the robot arm's object region from robot.yaml."
    )
    min_distance: FiniteFloat | None = Field(
        default=None,
        ge=0.0,
        le=1.0,
        description="Placed at least this far (m, between bounding circles in xy) from every "
        "object placed before it, redrawing up to 100 times (the reference's distractors "
        "min_object_distance). Default: placed independently.",
    )
    orientations: list[Vec3] | None = Field(
        default=None,
        description="Base orientations (xyz Euler, degrees) drawn uniformly per episode.",
    )
    category: str | None = None

    @field_validator("scale", mode="before")
    @classmethod
    def _scalar_scale(cls, value: Any) -> Any:
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return (value, value, value)
        return value

    @field_validator("scale")
    @classmethod
    def _positive_scale(cls, value: tuple[float, float, float]) -> tuple[float, float, float]:
        if any(v <= 0 for v in value):
            raise ValueError(f"scale must be positive, got {list(value)}")
        return value


class PhysicsConfig(StrictModel):
    """MuJoCo options. Elliptic cones with impratio 10 and the noslip pass keep friction grasps
    from creeping.

    ``noslip_iterations`` 10: MuJoCo's soft friction lets a held object turn or slide slowly
    under any load inside its friction limit (each friction row is regularised, R > 0; with
    elliptic cones a torsional row's R is the sliding row's times (mu_slide / mu_torsion)^2,
    engine_core_constraint.c, so the pads' torsion is the softest). The noslip pass re-solves
    the friction rows with R = 0 after the main solver (MuJoCo docs, Computation > Solver
    settings: "When contact slip is a problem ... enable the Noslip solver"), so an object
    sticks inside the limit and slips beyond it. 10 is chosen (5 already stops the creep of
    docs/interndata.md's example bottle); 0 restores the soft model."""

    timestep: FiniteFloat = Field(default=0.002, gt=0.0, le=0.05)
    integrator: Literal["implicitfast", "implicit", "euler", "rk4"] = "implicitfast"
    cone: Literal["elliptic", "pyramidal"] = "elliptic"
    impratio: FiniteFloat = Field(default=10.0, ge=1.0, le=1000.0)
    noslip_iterations: int = Field(default=10, ge=0, le=100)
    solver_iterations: int = Field(default=100, ge=1, le=10_000)
    gravity: Vec3 = (0.0, 0.0, -9.81)
    table_contact: bool = Field(
        default=True,
        description="Robot-table contact (the reference disables it: neglect_collision_names).",
    )


# Physics steps per control step above which a task is refused: 1/30 s at 1e-9 s would be 3.3e7
# steps per control step and hours per episode. Chosen, no public source: 10^4 is 60x the
# default (1/30 s at 0.002 s = 17) and still runs an episode in well under a minute.
MAX_SUBSTEPS = 10_000


class EpisodeLimits(StrictModel):
    """Bounds of one episode in a run (``harness.sim.budget``); past either it is ``timeout``.

    Chosen, no public source: a canonical episode takes ~0.2-2 s and ~10^4 physics steps, so
    both defaults leave a wide margin and only catch runaway episodes. A sweep sets them per
    task, or for all tasks with an axis such as ``limits.wall_time_s: [300]``."""

    wall_time_s: FiniteFloat = Field(default=120.0, gt=0.0, le=86_400.0)
    sim_steps: int = Field(default=2_000_000, ge=1, le=10**10)


GRIP_KEYS = ("force_limit", "pad_friction", "pad_torsion", "kp", "kv", "armature", "speed", "grasp")


class GripperChoice(StrictModel):
    """The task's gripper (``robot: {name: ..., gripper: {...}}``): a robot.yaml variant and
    overrides of its grip physics, each None = the robot.yaml value."""

    variant: str | None = Field(default=None, description="A gripper variant of robot.yaml.")
    force_limit: FiniteFloat | None = Field(default=None, gt=0.0, le=10_000.0)
    pad_friction: FiniteFloat | None = Field(default=None, gt=0.0, le=10.0)
    pad_torsion: FiniteFloat | None = Field(default=None, ge=0.0, le=1.0)
    kp: FiniteFloat | None = Field(default=None, gt=0.0, le=1e6)
    kv: FiniteFloat | None = Field(default=None, ge=0.0, le=1e5)
    armature: FiniteFloat | None = Field(
        default=None, ge=0.0, le=100.0, description="Finger joint armature (kg)."
    )
    speed: FiniteFloat | None = Field(
        default=None, gt=0.0, le=10.0, description="Finger speed that times open / close (m/s)."
    )
    grasp: Literal["force", "position"] | None = Field(
        default=None, description="force-controlled or position-controlled closing."
    )

    def overrides(self) -> dict[str, float | str]:
        """The grip physics values this task sets (robot.yaml keys)."""
        return {key: value for key in GRIP_KEYS if (value := getattr(self, key)) is not None}


class TimingChoice(StrictModel):
    """The task's scaling of the robot's chosen timing limits (``robot: {name, timing: {...}}``):
    each a factor on robot.yaml's values, None = 1 (issue 55: the acceleration and jerk limits
    without a public source are swept through these). ``acceleration_scale`` /
    ``jerk_scale`` scale every arm joint's, ``lift_acceleration_scale`` /
    ``lift_jerk_scale`` the lift's."""

    acceleration_scale: FiniteFloat | None = Field(default=None, gt=0.0, le=100.0)
    jerk_scale: FiniteFloat | None = Field(default=None, gt=0.0, le=100.0)
    lift_acceleration_scale: FiniteFloat | None = Field(default=None, gt=0.0, le=100.0)
    lift_jerk_scale: FiniteFloat | None = Field(default=None, gt=0.0, le=100.0)

    def factors(self, joints: Sequence[str], lift_joint: str | None) -> tuple[Any, Any]:
        """Per joint of ``joints``: the (acceleration, jerk) factors."""
        import numpy as np

        arm_a, arm_j = self.acceleration_scale or 1.0, self.jerk_scale or 1.0
        lift_a, lift_j = self.lift_acceleration_scale or 1.0, self.lift_jerk_scale or 1.0
        is_lift = np.array([name == lift_joint for name in joints])
        return np.where(is_lift, lift_a, arm_a), np.where(is_lift, lift_j, arm_j)


def _split_robot_mapping(data: Any) -> Any:
    """``robot: {name: fr3, gripper: {...}}`` -> ``robot: fr3`` + ``gripper: {...}``."""
    if not isinstance(data, dict) or not isinstance(data.get("robot"), dict):
        return data
    robot, data = dict(data["robot"]), dict(data)
    for key in robot:
        if key not in ("name", "gripper", "timing"):
            raise KeyedValueError(
                ("robot", key), f"unknown key{suggest(str(key), ['name', 'gripper', 'timing'])}"
            )
    if "name" not in robot:
        raise KeyedValueError("robot", "a robot mapping needs name (robots/<name> or a robot.yaml)")
    data["robot"] = robot["name"]
    if "gripper" in robot:
        if data.get("gripper") is not None:
            raise KeyedValueError(("robot", "gripper"), "gripper is given twice")
        try:
            data["gripper"] = GripperChoice.model_validate(robot["gripper"] or {})
        except ValidationError as exc:
            err = exc.errors()[0]
            loc = tuple(p for p in err["loc"] if isinstance(p, (str, int)))
            raise KeyedValueError(("robot", "gripper", *loc), err["msg"]) from None
    if "timing" in robot:
        if data.get("timing") is not None:
            raise KeyedValueError(("robot", "timing"), "timing is given twice")
        try:
            data["timing"] = TimingChoice.model_validate(robot["timing"] or {})
        except ValidationError as exc:
            err = exc.errors()[0]
            loc = tuple(p for p in err["loc"] if isinstance(p, (str, int)))
            raise KeyedValueError(("robot", "timing", *loc), err["msg"]) from None
    return data


class TaskConfig(StrictModel):
    """One pick task: robot arm, objects, physics and the pick block."""

    name: str = Field(default="task", min_length=1)
    robot: str = Field(min_length=1, description="Robot name (robots/<name>) or robot.yaml path.")
    gripper: GripperChoice = Field(
        default_factory=GripperChoice,
        description="Gripper variant and grip physics; in a file: robot: {name, gripper}.",
    )
    timing: TimingChoice = Field(
        default_factory=TimingChoice,
        description="Factors on the robot's chosen acceleration / jerk limits; in a file: "
        "robot: {name, timing}.",
    )
    arm: Literal["left", "right"] = "left"
    robot_placement: Placement | None = Field(
        default=None, description="Robot root placement; default from robot.yaml."
    )
    home: list[FiniteFloat] | None = Field(default=None, description="Arm home joint values.")
    home_noise_std: list[Annotated[float, Field(ge=0.0, allow_inf_nan=False)]] | None = None
    objects: list[ObjectConfig] = Field(min_length=1)
    physics: PhysicsConfig = Field(default_factory=PhysicsConfig)
    pick: PickConfig = Field(default_factory=PickConfig)
    max_episode_length: int = Field(default=500, ge=1, le=1_000_000)
    limits: EpisodeLimits = Field(default_factory=EpisodeLimits)
    control_dt: FiniteFloat = Field(
        default=1.0 / 30.0, gt=0.0, le=0.5, description="Control step (s); the reference's 1/30."
    )
    source: str | None = Field(default=None, description="File this task was loaded from.")
    not_runnable: str | None = Field(
        default=None,
        description="Why this pick cannot run on its own: set by the InternData mapper for a "
        "pick whose object an earlier skill of the file handles (a handover's second pick "
        "takes it from the other gripper). Its episodes are 'not_runnable' rows, in no rate.",
    )
    handover: HandoverPrelude | None = Field(
        default=None,
        description="A handover's second pick: the other arm's pick and goto__pose run first "
        "in the same episode, and this pick takes the object from that gripper in mid-air "
        "(harness.episode.handover; set by the InternData mapper).",
    )

    @model_validator(mode="before")
    @classmethod
    def _robot_mapping(cls, data: Any) -> Any:
        return _split_robot_mapping(data)

    @model_validator(mode="after")
    def _consistent(self) -> TaskConfig:
        self._check_gripper_variant()
        names = [obj.name for obj in self.objects]
        for index, name in enumerate(names):
            if name in names[:index]:
                raise KeyedValueError(
                    ("objects", index, "name"), f"object names must be unique, {name!r} repeats"
                )
        if self.pick.objects is None:
            self.pick = self.pick.model_copy(update={"objects": [names[0]]})
        if self.pick.objects and self.pick.objects[0] in names:
            index = names.index(self.pick.objects[0])
            if self.objects[index].fixed:
                raise KeyedValueError(
                    ("objects", index, "fixed"),
                    f"object {names[index]!r} is picked, so it cannot be a fixed fixture",
                )
        for index, name in enumerate(self.pick.objects or []):
            if name not in names:
                raise KeyedValueError(
                    ("pick", "objects", index),
                    f"unknown object {name!r}{suggest(name, names)} (objects: {names})",
                )
        if self.control_dt < self.physics.timestep:
            given_dt = "control_dt" in self.model_fields_set
            raise KeyedValueError(
                "control_dt" if given_dt else ("physics", "timestep"),
                f"control_dt ({self.control_dt:g} s) must be at least physics.timestep "
                f"({self.physics.timestep:g} s)",
            )
        substeps = self.control_dt / self.physics.timestep
        if substeps > MAX_SUBSTEPS:
            raise KeyedValueError(
                ("physics", "timestep"),
                f"{self.physics.timestep:g} s makes {substeps:,.0f} physics steps per control "
                f"step ({self.control_dt:g} s), above {MAX_SUBSTEPS:,}: an episode would not end",
            )
        home, noise = self.home, self.home_noise_std
        if home is not None and noise is not None and len(home) != len(noise):
            raise KeyedValueError(
                "home_noise_std",
                f"home_noise_std has {len(noise)} values but home has {len(home)}",
            )
        return self

    def _check_gripper_variant(self) -> None:
        from harness.config.robot_registry import gripper_variant_names

        variant = self.gripper.variant
        names = gripper_variant_names(self.robot) if variant is not None else None
        if variant is not None and names is not None and variant not in names:
            raise KeyedValueError(
                ("robot", "gripper", "variant"),
                f"robot {self.robot!r} has no gripper variant {variant!r}{suggest(variant, names)}"
                f" (variants: {', '.join(names)})",
            )

    @property
    def target_object(self) -> ObjectConfig:
        name = (self.pick.objects or [self.objects[0].name])[0]
        return next(obj for obj in self.objects if obj.name == name)

    def base_dir(self) -> Path:
        """Folder that relative paths in this task are resolved against."""
        return Path(self.source).resolve().parent if self.source else Path.cwd()
