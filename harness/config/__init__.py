"""Configuration: the Pick block, a task, a sweep; YAML loading with located errors.

``PickConfig`` (``pick``) carries every key of the InternDataEngine Pick skill with the reference
defaults, plus the harness keys. ``TaskConfig`` (``task``) is one robot arm picking one object;
``SweepConfig`` (``sweep``) expands tasks over dotted-key axes. All models forbid unknown keys
and suggest the closest one.

Loading (``loading``, ``validation``) reports the first problem as one line,
``file:line key.path: message``. This package re-exports the public names; its modules import
each other directly, never through this file.
"""

from harness.config.errors import ConfigError, KeyedValueError
from harness.config.filters import (
    DIRECTIONS,
    AxisFilter,
    Direction,
    FilterSpec,
    reversed_band_message,
)
from harness.config.loading import kind_of, load_any, load_sweep, load_task, parse_text, read_yaml
from harness.config.overrides import apply_overrides, parse_set_value, set_dotted
from harness.config.physics_warnings import physics_warnings, warning_lines
from harness.config.pick import PickConfig
from harness.config.sweep import RandomAxis, SweepConfig, check_dotted_key
from harness.config.task import ObjectConfig, PhysicsConfig, Placement, TaskConfig
from harness.config.validation import (
    describe_validation_error,
    error_from_validation,
    validate_model,
)
from harness.config.values import FiniteFloat, Probability, StrictModel, Vec3

__all__ = [
    "DIRECTIONS",
    "AxisFilter",
    "ConfigError",
    "Direction",
    "FilterSpec",
    "FiniteFloat",
    "KeyedValueError",
    "ObjectConfig",
    "PhysicsConfig",
    "PickConfig",
    "Placement",
    "Probability",
    "RandomAxis",
    "StrictModel",
    "SweepConfig",
    "TaskConfig",
    "Vec3",
    "apply_overrides",
    "check_dotted_key",
    "describe_validation_error",
    "error_from_validation",
    "kind_of",
    "load_any",
    "load_sweep",
    "load_task",
    "parse_set_value",
    "parse_text",
    "physics_warnings",
    "read_yaml",
    "reversed_band_message",
    "set_dotted",
    "validate_model",
    "warning_lines",
]
