"""A sweep: tasks x points x seeds, with points from a grid over dotted-key axes or random draws."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field, field_validator, model_validator

from harness.config.errors import KeyedValueError
from harness.config.messages import suggest
from harness.config.pick import PickConfig
from harness.config.task import GripperChoice, ObjectConfig, TaskConfig, TimingChoice
from harness.config.values import FiniteFloat, StrictModel


class RandomAxis(StrictModel):
    """A random axis: uniform over [low, high], or a uniform choice among ``choices``."""

    low: FiniteFloat | None = None
    high: FiniteFloat | None = None
    choices: list[Any] | None = None

    @model_validator(mode="after")
    def _one_form(self) -> RandomAxis:
        low, high = self.low, self.high
        ranged = low is not None and high is not None
        if ranged == (self.choices is not None):
            raise ValueError("give either low and high, or choices")
        if low is not None and high is not None and low > high:
            raise KeyedValueError("high", f"low ({self.low}) must be <= high ({self.high})")
        if self.choices is not None and not self.choices:
            raise KeyedValueError("choices", "choices must not be empty")
        return self


TASK_KEYS = frozenset(TaskConfig.model_fields)
ROBOT_KEYS = ("name", "gripper", "timing")


def canonical_key(key: str, target_index: int = 0) -> str:
    """The key in a task's ``model_dump``: ``object.`` is ``objects.<target_index>.`` (the
    picked object, ``pick.objects[0]``), ``robot.gripper.`` is ``gripper.`` and ``robot.name``
    is ``robot`` (a file's ``robot: {name, gripper}``)."""
    parts = key.split(".")
    if parts[0] == "object":
        parts = ["objects", str(target_index), *parts[1:]]
    elif parts[0] == "robot" and len(parts) > 1:
        parts = ["robot"] if parts[1:] == ["name"] else parts[1:]
    return ".".join(parts)


def _nested_keys() -> dict[str, frozenset[str]]:
    """Dotted keys under each task section that has a model of its own (``pick.*``, ...)."""
    out: dict[str, frozenset[str]] = {
        "pick": frozenset(PickConfig.model_fields),
        "object": frozenset(ObjectConfig.model_fields),
    }
    for name, info in TaskConfig.model_fields.items():
        fields = getattr(info.annotation, "model_fields", None)
        if name != "pick" and isinstance(fields, dict):
            out[name] = frozenset(fields)
    return out


def _suggest_task_key(key: str) -> str:
    """``; did you mean 'pick.filter_z_dir'?`` when the key is a section's key without its
    section (``filter_z_dir=...``); else the closest top-level task key, or ``""``."""
    head, _, rest = key.partition(".")
    for section, keys in _nested_keys().items():
        if head in keys:
            return f"; did you mean {'.'.join([section, head] + ([rest] if rest else []))!r}?"
    dotted = [f"{section}.{k}" for section, keys in _nested_keys().items() for k in keys]
    return suggest(head, TASK_KEYS) or suggest(key, dotted)


def check_dotted_key(key: str) -> str:
    """``key`` if it names a task key (``object.`` is the target object), else KeyedValueError."""
    parts = key.split(".")
    if not all(parts):
        raise KeyedValueError(
            (key,), f"axis key {key!r} is not a dotted key like 'pick.filter_z_dir'"
        )
    negative = next((part for part in parts if part.startswith("-") and part[1:].isdigit()), None)
    if negative is not None:  # Python would count from the end; a key names one item
        raise KeyedValueError(
            (key,),
            f"axis key {key!r}: negative list index {negative} (give the item's position, "
            "counted from 0)",
        )
    head = parts[0]
    if head == "object":  # shorthand for the target object
        parts = ["objects", "0", *parts[1:]]
        head = "objects"
    if head not in TASK_KEYS:
        raise KeyedValueError(
            (key,), f"axis key {key!r}: unknown task key {head!r}{_suggest_task_key(key)}"
        )
    if head == "robot" and len(parts) > 1 and parts[1] not in ROBOT_KEYS:
        raise KeyedValueError(
            (key,),
            f"axis key {key!r}: unknown robot key {parts[1]!r}{suggest(parts[1], ROBOT_KEYS)}",
        )
    if (head == "robot" and len(parts) > 2) or (head in ("gripper", "timing") and len(parts) > 1):
        section = parts[1] if head == "robot" else head
        field = parts[2] if head == "robot" else parts[1]
        model = TimingChoice if section == "timing" else GripperChoice
        if field not in model.model_fields:
            raise KeyedValueError(
                (key,),
                f"axis key {key!r}: unknown {section} key {field!r}"
                f"{suggest(field, model.model_fields)}",
            )
    if head == "pick" and len(parts) > 1 and parts[1] not in PickConfig.model_fields:
        raise KeyedValueError(
            (key,),
            f"axis key {key!r}: unknown pick key {parts[1]!r}"
            f"{suggest(parts[1], PickConfig.model_fields)}",
        )
    return key


def _first_equal(earlier: list[Any], value: Any) -> int | None:
    """Index of the first item of ``earlier`` equal to ``value`` (as the episode id sees it:
    ``0.02`` and ``2.0e-2`` are one value), else None."""
    for index, item in enumerate(earlier):
        try:
            if item == value and type(item) is type(value):
                return index
        except Exception:
            continue
    return None


class SweepConfig(StrictModel):
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
    record: str = Field(
        default="failures", pattern=r"^(none|failures|invalid|all|sample:[1-9][0-9]*)$"
    )
    share: bool = Field(
        default=True,
        description="Points that differ only in selection keys (filters, direction_to_obj) "
        "share each seed's candidate evaluations (harness.episode.candidate_cache); the rows are "
        "the same either way. false evaluates every point on its own.",
    )

    @field_validator("name")
    @classmethod
    def _plain_name(cls, name: str) -> str:
        """The name becomes a folder name (``reports/<name>-<time>``): ``.``, ``..`` and a
        leading ``-`` (read as a flag by shell tools) are refused."""
        if set(name) == {"."} or name.startswith("-"):
            raise ValueError(f"{name!r} is not a plain file name (letters, digits, _ . -)")
        return name

    @field_validator("axes")
    @classmethod
    def _grid_axes(cls, axes: dict[str, list[Any]]) -> dict[str, list[Any]]:
        for key, values in axes.items():
            check_dotted_key(key)
            if not values:
                raise KeyedValueError((key,), f"axis {key!r} has no values")
            for index, value in enumerate(values):
                first = _first_equal(values[:index], value)
                if first is not None:
                    raise KeyedValueError(
                        (key, index),
                        f"axis {key!r}: value {value!r} (item {index}) equals item {first} "
                        f"({values[first]!r}); both points would share episode ids and one "
                        f"would be dropped, so list each value once",
                    )
        return axes

    @field_validator("random_axes")
    @classmethod
    def _random_axes(cls, axes: dict[str, RandomAxis]) -> dict[str, RandomAxis]:
        for key in axes:
            check_dotted_key(key)
        return axes

    @model_validator(mode="after")
    def _mode_matches(self) -> SweepConfig:
        if self.mode == "random" and not self.random_axes:
            raise KeyedValueError("mode", "mode 'random' needs random_axes")
        if self.mode == "grid" and self.random_axes:
            raise KeyedValueError("random_axes", "random_axes are only used with mode: random")
        return self
