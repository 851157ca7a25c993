"""Direction filters of the Pick skill: ``AxisFilter``, its YAML form, and band messages.

A filter is written ``[direction, angle]`` or ``[direction, angle1, angle2]`` in YAML;
``FilterSpec`` parses that form into an ``AxisFilter`` and writes it back as a list.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, PlainSerializer, field_validator

from harness.config.messages import short_repr

Direction = Literal["forward", "backward", "upward", "downward"]
DIRECTIONS: tuple[str, ...] = ("forward", "backward", "upward", "downward")


class AxisFilter(BaseModel):
    """A reference direction filter: ``[direction, angle]`` or ``[direction, angle1, angle2]``.

    Angles are degrees measured from base +X (forward/backward) or base +Z (upward/downward),
    never from the named direction (reference section 4.2).
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
        angles = self.angles
        if len(angles) != 2:  # not a band (is_band)
            return False
        a1, a2 = angles
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
            raise ValueError(f"angle {short_repr(angle)} must be in [0, 180] degrees") from None
    for angle in degrees:  # checked here too, so the error names the filter key, not 'angles'
        if not math.isfinite(angle) or not 0.0 <= angle <= 180.0:
            raise ValueError(f"angle {angle!r} must be in [0, 180] degrees")
    return {"direction": direction, "angles": tuple(degrees)}


FilterSpec = Annotated[
    AxisFilter | None,
    BeforeValidator(_parse_axis_filter),
    PlainSerializer(lambda f: None if f is None else f.as_list(), return_type=Any),
]


def reversed_band_message(key: str, spec: AxisFilter) -> str:
    """Explain the 3-element ordering rule for a filter that can never pass."""
    angles = spec.angles
    if len(angles) != 2:
        raise ValueError(f"{key} {spec.as_list()} is not a band [direction, angle1, angle2]")
    a1, a2 = angles
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
