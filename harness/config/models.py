"""Configuration models: the Pick block, a task, a sweep; YAML loading with located errors.

``PickConfig`` carries every key of the InternDataEngine Pick skill with the reference defaults
(docs/reference-pick-skill.md section 8), so a reference pick block pastes in unchanged,
plus the harness keys (``semantics``, ``approach_filter``, ``facing_filter``, ``timing``, the
strict-verdict thresholds). ``TaskConfig`` is one robot arm picking one object; ``SweepConfig``
expands tasks over dotted-key axes. All models forbid unknown keys and suggest the closest one.

Loading reports the first problem as one line, ``file:line key.path: message``.
"""

from __future__ import annotations

import difflib
import math
from pathlib import Path
from typing import Annotated, Any, Literal, TypeVar

import yaml
from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    PlainSerializer,
    ValidationError,
    field_validator,
    model_validator,
)

from harness.config.yamlio import KeyPath, YamlDocument, format_key_path, parse_yaml
from harness.errors import HarnessError

# --------------------------------------------------------------------------------------------
# Errors


class ConfigError(HarnessError, ValueError):
    """A configuration problem, located by file, line and key path when known."""

    def __init__(
        self,
        message: str,
        *,
        file: str | Path | None = None,
        line: int | None = None,
        key: str | None = None,
    ) -> None:
        self.message = message
        self.file = str(file) if file is not None else None
        self.line = line
        self.key = key
        super().__init__(self.one_line())

    def one_line(self) -> str:
        """``file:line key.path: message`` with whatever parts are known."""
        where = ""
        if self.file:
            where = self.file + (f":{self.line}" if self.line else "")
        if self.key:
            where = f"{where} {self.key}" if where else self.key
        text = f"{where}: {self.message}" if where else self.message
        return text.replace("\r", "\\r").replace("\n", "\\n")  # always exactly one line

    def with_file(self, file: str | Path | None) -> ConfigError:
        """The same error attributed to ``file`` when it has no file yet."""
        if file and not self.file:
            return ConfigError(self.message, file=file, line=self.line, key=self.key)
        return self


class KeyedValueError(ValueError):
    """A cross-key validation failure that names the key it is about.

    A model validator sees the whole model, so pydantic locates its errors at the model itself;
    raising this instead lets ``error_from_validation`` point at ``key`` (relative to the model),
    so the one-line error carries the key path and that key's line.
    """

    def __init__(self, key: str | KeyPath, message: str) -> None:
        super().__init__(message)
        self.key: KeyPath = (key,) if isinstance(key, str) else tuple(key)


# --------------------------------------------------------------------------------------------
# Direction filters

Direction = Literal["forward", "backward", "upward", "downward"]
DIRECTIONS: tuple[str, ...] = ("forward", "backward", "upward", "downward")


class AxisFilter(BaseModel):
    """A reference direction filter: ``[direction, angle]`` or ``[direction, angle1, angle2]``.

    Angles are degrees measured from base +X (forward/backward) or base +Z (upward/downward),
    never from the named direction (docs/reference-pick-skill.md section 4.2).
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    direction: Direction
    angles: tuple[float] | tuple[float, float]

    @field_validator("angles")
    @classmethod
    def _angles_in_range(cls, angles: tuple[float, ...]) -> tuple[float, ...]:
        for angle in angles:
            if not math.isfinite(angle) or not 0.0 <= angle <= 180.0:
                raise ValueError(f"angle {angle!r} must be in [0, 180] degrees")
        return angles

    @property
    def is_band(self) -> bool:
        return len(self.angles) == 2

    def never_passes(self) -> bool:
        """True for a 3-element form whose angle order makes the reference mask always empty.

        forward/upward keep cos(a1) <= e <= cos(a2), which needs a1 >= a2; backward/downward
        keep cos(a2) <= e <= cos(a1), which needs a1 <= a2.
        """
        if not self.is_band:
            return False
        a1, a2 = self.angles
        if self.direction in ("forward", "upward"):
            return a1 < a2
        return a1 > a2

    def as_list(self) -> list[Any]:
        return [self.direction, *self.angles]


def _parse_axis_filter(value: Any) -> Any:
    if value is None or isinstance(value, AxisFilter):
        return value
    if isinstance(value, dict):
        return value
    if not isinstance(value, (list, tuple)) or len(value) not in (2, 3):
        raise ValueError(
            "expected [direction, angle] or [direction, angle1, angle2], "
            f"e.g. ['downward', 140]; got {value!r}"
        )
    direction, *angles = value
    if direction not in DIRECTIONS:
        raise ValueError(
            f"unknown direction {direction!r}; Pick knows only {', '.join(DIRECTIONS)}"
        )
    degrees: list[float] = []
    for angle in angles:
        if isinstance(angle, bool) or not isinstance(angle, (int, float)):
            raise ValueError(f"angle {angle!r} must be a number of degrees")
        try:
            degrees.append(float(angle))
        except OverflowError:  # an int too large for a float
            raise ValueError(f"angle {_short_repr(angle)} must be in [0, 180] degrees") from None
    for angle in degrees:  # checked here too, so the error names the filter key, not 'angles'
        if not math.isfinite(angle) or not 0.0 <= angle <= 180.0:
            raise ValueError(f"angle {angle!r} must be in [0, 180] degrees")
    return {"direction": direction, "angles": tuple(degrees)}


FilterSpec = Annotated[
    AxisFilter | None,
    BeforeValidator(_parse_axis_filter),
    PlainSerializer(lambda f: None if f is None else f.as_list(), return_type=Any),
]

# --------------------------------------------------------------------------------------------
# Small value types

FiniteFloat = Annotated[float, Field(allow_inf_nan=False)]
Vec3 = tuple[FiniteFloat, FiniteFloat, FiniteFloat]
Probability = Annotated[float, Field(ge=0.0, le=1.0, allow_inf_nan=False)]


class _Strict(BaseModel):
    """Base: unknown keys are errors; values are validated on assignment too."""

    model_config = ConfigDict(extra="forbid", validate_assignment=True)


# --------------------------------------------------------------------------------------------
# Pick


class PickConfig(_Strict):
    """Every key of the reference Pick skill (reference defaults), plus the harness keys."""

    # Reference keys (docs/reference-pick-skill.md section 8).
    objects: list[str] | None = Field(
        default=None,
        min_length=1,
        description="Target object names; the first is picked (default: the task's first).",
    )
    npy_name: str = Field(default="Aligned_grasp_sparse.npy", min_length=1)
    grasp_scale: FiniteFloat = Field(default=1.0, gt=0.0)
    tcp_offset: FiniteFloat | None = Field(default=None, gt=0.0, lt=0.5)
    constraints: tuple[Literal["x", "y", "z"], Probability, Probability] | None = None
    final_gripper_state: Literal[1, -1] = -1
    fixed_orientation: tuple[FiniteFloat, FiniteFloat, FiniteFloat, FiniteFloat] | None = None
    filter_x_dir: FilterSpec = None
    filter_y_dir: FilterSpec = None
    filter_z_dir: FilterSpec = None
    direction_to_obj: Literal["left", "right"] | None = None
    pre_grasp_offset: FiniteFloat = Field(default=0.1, ge=-0.5, le=0.5)
    pre_grasp_hold_vec_weight: (
        tuple[FiniteFloat, FiniteFloat, FiniteFloat, FiniteFloat, FiniteFloat, FiniteFloat] | None
    ) = None
    gripper_change_steps: int = Field(default=40, ge=1, le=10_000)
    post_grasp_offset_min: FiniteFloat = Field(default=0.05, ge=0.0, le=1.0)
    post_grasp_offset_max: FiniteFloat = Field(default=0.05, ge=0.0, le=1.0)
    return_to_pregrasp: bool = False
    lift_th: FiniteFloat = Field(default=0.0, ge=0.0, le=1.0)
    ignore_substring: list[str] = Field(default_factory=list)
    test_mode: Literal["forward", "ik"] = "forward"
    t_eps: FiniteFloat = Field(default=1e-3, gt=0.0)
    o_eps: FiniteFloat = Field(default=5e-3, gt=0.0)
    process_valid: bool = True

    # Keys that appear in reference configs but are never read there; accepted and ignored.
    name: Literal["pick"] | None = None
    close_wait_steps: int | None = None
    update_pose_cost_metric_none: bool | None = None
    constrain_grasp_approach: bool | None = None

    # Harness keys.
    semantics: Literal["reference", "strict"] = "reference"
    approach_filter: FilterSpec = Field(
        default=None,
        description="Robot-neutral filter on the approach axis (robot.yaml approach_axis).",
    )
    facing_filter: FilterSpec = Field(
        default=None,
        description="Robot-neutral filter on the facing axis (robot.yaml facing_axis).",
    )
    strict_sampling: bool = Field(
        default=False,
        description="strict: order candidates by weighted sampling without replacement "
        "(weights 1/score) instead of plain score order.",
    )
    timing: Literal["toppra", "ruckig"] = "toppra"
    speed_scale: FiniteFloat = Field(default=1.0, gt=0.0, le=1.0)
    min_finger_force: FiniteFloat = Field(
        default=0.5, ge=0.0, description="strict: normal force each finger must carry (N)."
    )
    hold_time: FiniteFloat = Field(
        default=1.0, ge=0.0, le=60.0, description="strict: hold after the lift (s)."
    )
    max_slip: FiniteFloat = Field(
        default=0.005, gt=0.0, description="strict: object slip allowed in the hold (m)."
    )

    @field_validator("fixed_orientation")
    @classmethod
    def _unit_quaternion(cls, q: tuple[float, ...] | None) -> tuple[float, ...] | None:
        if q is None:
            return q
        norm = math.sqrt(sum(c * c for c in q))
        if abs(norm - 1.0) > 1e-3:
            raise ValueError(f"fixed_orientation must be a unit wxyz quaternion (norm {norm:.4g})")
        return q

    @model_validator(mode="after")
    def _cross_checks(self) -> PickConfig:
        if self.post_grasp_offset_min > self.post_grasp_offset_max:
            given_max = "post_grasp_offset_max" in self.model_fields_set
            raise KeyedValueError(
                "post_grasp_offset_max" if given_max else "post_grasp_offset_min",
                f"post_grasp_offset_min ({self.post_grasp_offset_min}) must be <= "
                f"post_grasp_offset_max ({self.post_grasp_offset_max})",
            )
        if self.constraints is not None and self.constraints[1] > self.constraints[2]:
            raise KeyedValueError(
                "constraints",
                f"constraints [axis, rmin, rmax] needs rmin <= rmax, got {list(self.constraints)}",
            )
        if self.semantics == "strict":
            for key in (
                "filter_x_dir",
                "filter_y_dir",
                "filter_z_dir",
                "approach_filter",
                "facing_filter",
            ):
                spec: AxisFilter | None = getattr(self, key)
                if spec is not None and spec.never_passes():
                    raise KeyedValueError(key, reversed_band_message(key, spec))
        return self

    def axis_filters(self) -> dict[str, AxisFilter]:
        """The explicit per-axis filters that are set, keyed ``filter_x_dir`` etc."""
        return {
            key: spec
            for key in ("filter_x_dir", "filter_y_dir", "filter_z_dir")
            if (spec := getattr(self, key)) is not None
        }


def reversed_band_message(key: str, spec: AxisFilter) -> str:
    """Explain the 3-element ordering rule for a filter that can never pass."""
    a1, a2 = spec.angles
    if spec.direction in ("forward", "upward"):
        rule = "forward/upward bands need the larger angle first"
        fixed = [spec.direction, a2, a1]
    else:
        rule = "backward/downward bands need the smaller angle first"
        fixed = [spec.direction, a2, a1]
    return (
        f"{key} {spec.as_list()} can never pass: {rule} (angles are measured from base "
        f"+X or +Z); did you mean {fixed}?"
    )


# --------------------------------------------------------------------------------------------
# Task


class Placement(_Strict):
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
            if a > b:
                raise KeyedValueError(
                    "pos_range", f"pos_range axis {'xyz'[axis]}: min {a} must be <= max {b}"
                )
        if self.yaw_range[0] > self.yaw_range[1]:
            raise KeyedValueError(
                "yaw_range", f"yaw_range min {self.yaw_range[0]} must be <= max {self.yaw_range[1]}"
            )
        return self


class ObjectConfig(_Strict):
    """One object: a mesh (path, or the name of a default object), its grasps and physics."""

    name: str = Field(min_length=1)
    mesh: str = Field(min_length=1, description="Mesh path (relative to the YAML) or object name.")
    grasps: str | None = Field(default=None, description="Grasp file; default by naming rule.")
    scale: tuple[FiniteFloat, FiniteFloat, FiniteFloat] = (1.0, 1.0, 1.0)
    mass: FiniteFloat = Field(default=0.1, gt=0.0, le=100.0)
    friction: FiniteFloat = Field(default=1.0, gt=0.0, le=10.0)
    placement: Placement | None = Field(
        default=None, description="Default: the robot arm's object region from robot.yaml."
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


class PhysicsConfig(_Strict):
    """MuJoCo options. Elliptic cones with impratio 10 keep friction grasps from creeping."""

    timestep: FiniteFloat = Field(default=0.002, gt=0.0, le=0.05)
    integrator: Literal["implicitfast", "implicit", "euler", "rk4"] = "implicitfast"
    cone: Literal["elliptic", "pyramidal"] = "elliptic"
    impratio: FiniteFloat = Field(default=10.0, ge=1.0, le=1000.0)
    noslip_iterations: int = Field(default=0, ge=0, le=100)
    solver_iterations: int = Field(default=100, ge=1, le=10_000)
    gravity: Vec3 = (0.0, 0.0, -9.81)
    table_contact: bool = Field(
        default=True,
        description="Robot-table contact (the reference disables it: neglect_collision_names).",
    )


class TaskConfig(_Strict):
    """One pick task: robot arm, objects, physics and the pick block."""

    name: str = Field(default="task", min_length=1)
    robot: str = Field(min_length=1, description="Robot name (robots/<name>) or robot.yaml path.")
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
    control_dt: FiniteFloat = Field(
        default=1.0 / 30.0, gt=0.0, le=0.5, description="Control step (s); the reference's 1/30."
    )
    source: str | None = Field(default=None, description="File this task was loaded from.")

    @model_validator(mode="after")
    def _consistent(self) -> TaskConfig:
        names = [obj.name for obj in self.objects]
        for index, name in enumerate(names):
            if name in names[:index]:
                raise KeyedValueError(
                    ("objects", index, "name"), f"object names must be unique, {name!r} repeats"
                )
        if self.pick.objects is None:
            self.pick = self.pick.model_copy(update={"objects": [names[0]]})
        for index, name in enumerate(self.pick.objects or []):
            if name not in names:
                raise KeyedValueError(
                    ("pick", "objects", index),
                    f"unknown object {name!r}{_suggest(name, names)} (objects: {names})",
                )
        if self.control_dt < self.physics.timestep:
            given_dt = "control_dt" in self.model_fields_set
            raise KeyedValueError(
                "control_dt" if given_dt else ("physics", "timestep"),
                f"control_dt ({self.control_dt:g} s) must be at least physics.timestep "
                f"({self.physics.timestep:g} s)",
            )
        both = self.home is not None and self.home_noise_std is not None
        if both and len(self.home) != len(self.home_noise_std):  # type: ignore[arg-type]
            raise KeyedValueError(
                "home_noise_std",
                f"home_noise_std has {len(self.home_noise_std)} values but home has "  # type: ignore[arg-type]
                f"{len(self.home)}",  # type: ignore[arg-type]
            )
        return self

    @property
    def target_object(self) -> ObjectConfig:
        name = (self.pick.objects or [self.objects[0].name])[0]
        return next(obj for obj in self.objects if obj.name == name)

    def base_dir(self) -> Path:
        """Folder that relative paths in this task are resolved against."""
        return Path(self.source).resolve().parent if self.source else Path.cwd()


# --------------------------------------------------------------------------------------------
# Sweep


class RandomAxis(_Strict):
    """A random axis: uniform over [low, high], or a uniform choice among ``choices``."""

    low: FiniteFloat | None = None
    high: FiniteFloat | None = None
    choices: list[Any] | None = None

    @model_validator(mode="after")
    def _one_form(self) -> RandomAxis:
        ranged = self.low is not None and self.high is not None
        if ranged == (self.choices is not None):
            raise ValueError("give either low and high, or choices")
        if ranged and self.low > self.high:  # type: ignore[operator]
            raise KeyedValueError("high", f"low ({self.low}) must be <= high ({self.high})")
        if self.choices is not None and not self.choices:
            raise KeyedValueError("choices", "choices must not be empty")
        return self


TASK_KEYS = frozenset(TaskConfig.model_fields)


def _check_dotted_key(key: str) -> str:
    parts = key.split(".")
    if not all(parts):
        raise KeyedValueError(
            (key,), f"axis key {key!r} is not a dotted key like 'pick.filter_z_dir'"
        )
    head = parts[0]
    if head == "object":  # shorthand for the target object
        parts = ["objects", "0", *parts[1:]]
        head = "objects"
    if head not in TASK_KEYS:
        raise KeyedValueError(
            (key,), f"axis key {key!r}: unknown task key {head!r}{_suggest(head, TASK_KEYS)}"
        )
    if head == "pick" and len(parts) > 1 and parts[1] not in PickConfig.model_fields:
        raise KeyedValueError(
            (key,),
            f"axis key {key!r}: unknown pick key {parts[1]!r}"
            f"{_suggest(parts[1], PickConfig.model_fields)}",
        )
    return key


class SweepConfig(_Strict):
    """Tasks x points x seeds. Points come from a grid over ``axes`` or ``random`` draws."""

    name: str = Field(min_length=1, pattern=r"^[A-Za-z0-9_.-]+$")
    tasks: list[str | dict[str, Any]] = Field(
        min_length=1,
        description="Task YAML paths (relative to the sweep file), inline tasks, or "
        "{interndata: path, asset_root: dir, objects: {name: path}}.",
    )
    mode: Literal["grid", "random"] = "grid"
    axes: dict[str, list[Any]] = Field(default_factory=dict)
    random_axes: dict[str, RandomAxis] = Field(default_factory=dict)
    points: int = Field(default=1, ge=1, le=100_000, description="Random mode: number of draws.")
    episodes_per_point: int = Field(default=10, ge=1, le=100_000)
    seed: int = Field(default=0, ge=0)
    workers: int | None = Field(default=None, ge=1, le=1024)
    record: str = Field(default="failures", pattern=r"^(none|failures|all|sample:\d+)$")

    @field_validator("axes")
    @classmethod
    def _grid_axes(cls, axes: dict[str, list[Any]]) -> dict[str, list[Any]]:
        for key, values in axes.items():
            _check_dotted_key(key)
            if not values:
                raise KeyedValueError((key,), f"axis {key!r} has no values")
        return axes

    @field_validator("random_axes")
    @classmethod
    def _random_axes(cls, axes: dict[str, RandomAxis]) -> dict[str, RandomAxis]:
        for key in axes:
            _check_dotted_key(key)
        return axes

    @model_validator(mode="after")
    def _mode_matches(self) -> SweepConfig:
        if self.mode == "random" and not self.random_axes:
            raise KeyedValueError("mode", "mode 'random' needs random_axes")
        if self.mode == "grid" and self.random_axes:
            raise KeyedValueError("random_axes", "random_axes are only used with mode: random")
        return self


# --------------------------------------------------------------------------------------------
# Loading


def _suggest(key: str, valid: Any) -> str:
    close = difflib.get_close_matches(str(key), [str(v) for v in valid], n=1, cutoff=0.5)
    return f"; did you mean {close[0]!r}?" if close else ""


def _model_at(model: type[BaseModel], loc: tuple[Any, ...]) -> type[BaseModel] | None:
    """Follow a pydantic error location through nested models, for key suggestions."""
    current: Any = model
    for part in loc:
        if isinstance(part, int) or not isinstance(current, type):
            continue
        if not issubclass(current, BaseModel):
            return None
        field = current.model_fields.get(str(part))
        if field is None:
            continue
        annotation = field.annotation
        current = _innermost_model(annotation)
        if current is None:
            return None
    return current if isinstance(current, type) and issubclass(current, BaseModel) else None


def _innermost_model(annotation: Any) -> type[BaseModel] | None:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for arg in getattr(annotation, "__args__", ()) or ():
        found = _innermost_model(arg)
        if found is not None:
            return found
    return None


def _clean_loc(loc: tuple[Any, ...]) -> KeyPath:
    """Drop pydantic's union / function tags from a location, keep keys and indices."""
    out: list[str | int] = []
    for part in loc:
        tag = isinstance(part, str) and (
            part.startswith(("function-", "tagged-union", "json-or-python"))
            or part in {"AxisFilter", "str", "dict[str,any]", "list[str]", "none"}
            or "[" in part
        )
        if isinstance(part, (int, str)) and not tag:
            out.append(part)
    return tuple(out)


def describe_validation_error(
    exc: ValidationError, model: type[BaseModel]
) -> tuple[KeyPath, str, KeyPath]:
    """The first pydantic error as ``(key path, message, path to take the line from)``.

    Key paths are relative to ``model``. Used by ``error_from_validation`` and by loaders whose
    model keys come from other places in a file (``harness.config.interndata.mapper``).
    """
    errors = exc.errors(include_url=False)
    err = errors[0]
    if err.get("type") == "missing":
        # A misspelt key shows up as "missing" plus "extra"; the extra one explains both.
        parent = tuple(err.get("loc", ()))[:-1]
        for other in errors:
            if other.get("type") == "extra_forbidden" and tuple(other["loc"])[:-1] == parent:
                err = other
                break
    loc = _clean_loc(tuple(err.get("loc", ())))
    cause = (err.get("ctx") or {}).get("error")
    if isinstance(cause, KeyedValueError):
        loc = (*loc, *cause.key)
    message = str(err.get("msg", "invalid value"))
    if message.startswith("Value error, "):
        message = message[len("Value error, ") :]
    line_loc: KeyPath | None = None
    if err.get("type") == "extra_forbidden" and loc:
        parent = _model_at(model, loc[:-1]) or model
        message = f"unknown key{_suggest(str(loc[-1]), parent.model_fields)}"
    elif err.get("type") == "invalid_key":
        # YAML read a key as a non-string (1, null, a date); pydantic stringifies it in loc.
        bad_key = err.get("input")
        loc = loc[:-1]
        line_loc = (*loc, bad_key)
        message = (
            f"key {bad_key!r} is a {type(bad_key).__name__}, keys must be strings "
            "(quote it, or fix the name)"
        )
    elif err.get("type") == "missing" and loc and isinstance(loc[-1], int):
        message = f"too few values: item [{loc[-1]}] is missing"  # a short tuple
        loc = loc[:-1]
    elif err.get("type") == "missing":
        message = "required key is missing"
    elif "input" in err and err.get("type") not in ("value_error", "assertion_error"):
        message = f"{message} (got {_short_repr(err['input'])})"
    return loc, message, line_loc if line_loc is not None else loc


def error_from_validation(
    exc: ValidationError,
    model: type[BaseModel],
    doc: YamlDocument | None = None,
    prefix: KeyPath = (),
) -> ConfigError:
    """Turn the first pydantic error into a located one-line ConfigError."""
    loc, message, line_loc = describe_validation_error(exc, model)
    full = (*prefix, *loc)
    line = doc.line_of((*prefix, *line_loc)) if doc is not None else None
    file = doc.path if doc is not None else None
    return ConfigError(message, file=file, line=line, key=format_key_path(full) if full else None)


def _short_repr(value: Any, limit: int = 60) -> str:
    """``repr`` cut to ``limit`` characters, so one huge value cannot flood the error line."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def read_yaml(path: str | Path) -> YamlDocument:
    """Read and parse a YAML file; any I/O or syntax problem becomes a ConfigError."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError("file not found", file=path) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read file: {exc}", file=path) from None
    return parse_text(text, path)


def parse_text(text: str, path: str | Path | None = None) -> YamlDocument:
    """Parse YAML text; syntax errors become ConfigErrors with the line."""
    try:
        return parse_yaml(text, Path(path) if path is not None else None)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = mark.line + 1 if mark is not None else None
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        context = getattr(exc, "context", None)
        if context and not context.startswith("while "):  # e.g. "expected a single document"
            problem = f"{context}, {problem}"
        raise ConfigError(f"invalid YAML: {problem}", file=path, line=line) from None
    except (RecursionError, ValueError, TypeError) as exc:  # pathological documents
        raise ConfigError(f"invalid YAML: {exc}", file=path) from None


M = TypeVar("M", bound=BaseModel)


def validate_model(
    model: type[M], data: Any, doc: YamlDocument | None = None, prefix: KeyPath = ()
) -> M:
    """Validate ``data`` as ``model``; failures become a located ConfigError."""
    if not isinstance(data, dict):
        where = format_key_path(prefix) if prefix else None
        raise ConfigError(
            f"expected a mapping of {model.__name__} keys, got {type(data).__name__}",
            file=doc.path if doc else None,
            line=doc.line_of(prefix) if doc else None,
            key=where,
        )
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise error_from_validation(exc, model, doc, prefix) from None


def kind_of(data: Any) -> str:
    """Guess what a YAML document is: 'sweep', 'task' or 'interndata'."""
    if isinstance(data, dict):
        if "tasks" in data and isinstance(data["tasks"], list):
            first = data["tasks"][0] if data["tasks"] else None
            if isinstance(first, dict) and ("skills" in first or "robots" in first):
                return "interndata"
            return "sweep"
        if "robot" in data or "pick" in data:
            return "task"
    return "unknown"


def load_task(path: str | Path) -> TaskConfig:
    """Load a harness task YAML."""
    doc = read_yaml(path)
    data = doc.data
    if isinstance(data, dict):
        data = {**data, "source": str(Path(path))}
    return validate_model(TaskConfig, data, doc)


def load_sweep(path: str | Path) -> SweepConfig:
    """Load a sweep YAML (the tasks it lists are loaded when the sweep expands)."""
    doc = read_yaml(path)
    return validate_model(SweepConfig, doc.data, doc)


def load_any(path: str | Path) -> tuple[str, BaseModel | YamlDocument]:
    """Load a task or sweep YAML by sniffing its top-level keys (used by ``harness validate``)."""
    doc = read_yaml(path)
    kind = kind_of(doc.data)
    if kind == "sweep":
        return kind, validate_model(SweepConfig, doc.data, doc)
    if kind == "task":
        data = {**doc.data, "source": str(Path(path))}
        return kind, validate_model(TaskConfig, data, doc)
    if kind == "interndata":
        return kind, doc
    raise ConfigError(
        "not a task (needs 'robot' and 'objects') or a sweep (needs 'name' and 'tasks')",
        file=path,
        line=1,
    )


def set_dotted(data: dict[str, Any], key: str, value: Any) -> None:
    """Set ``pick.filter_z_dir`` / ``objects.0.mass`` / ``object.friction`` in a nested dict."""
    parts = key.split(".")
    if parts[0] == "object":
        parts = ["objects", "0", *parts[1:]]
    node: Any = data
    for index, part in enumerate(parts[:-1]):
        nxt = parts[index + 1]
        if isinstance(node, list):
            node = node[int(part)]
            continue
        if part not in node or node[part] is None:
            node[part] = [] if nxt.isdigit() else {}
        node = node[part]
    last = parts[-1]
    if isinstance(node, list):
        node[int(last)] = value
    else:
        node[last] = value


def parse_set_value(text: str) -> Any:
    """Parse the value of ``--set key=value`` as YAML (so lists and numbers work)."""
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError:
        return text


def apply_overrides(task: TaskConfig, overrides: dict[str, Any]) -> TaskConfig:
    """Return a validated copy of ``task`` with dotted-key overrides applied."""
    data = task.model_dump(mode="json", exclude_none=False)
    for key, value in overrides.items():
        try:
            _check_dotted_key(key)
            set_dotted(data, key, value)
        except KeyError as exc:  # str(KeyError) quotes its message
            raise ConfigError(str(exc.args[0]), file=task.source, key=key) from None
        except (ValueError, IndexError, TypeError) as exc:
            raise ConfigError(str(exc), file=task.source, key=key) from None
    try:
        return TaskConfig.model_validate(data)
    except ValidationError as exc:
        raise error_from_validation(exc, TaskConfig, None).with_file(task.source) from None
