"""Validated inputs of time parameterisation: vectors, limits (with the speed scale), waypoints
and joint names.

Every timing entry point checks its inputs the same way (finite, positive limits, matching DoF,
``speed_scale`` in (0, 1]) and normalises them to float arrays; :class:`TimingLimits` is the
limits value the episode passes around.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

# Consecutive waypoints closer than this (max-norm, rad or m) are one waypoint.
DUPLICATE_TOLERANCE = 1e-9


@dataclass(frozen=True)
class TimingLimits:
    """Per-joint velocity, acceleration and jerk limits (positive) and a speed scale in (0, 1]."""

    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray | None = None
    speed_scale: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "velocity", positive_vector(self.velocity, "velocity"))
        object.__setattr__(self, "acceleration", positive_vector(self.acceleration, "acceleration"))
        if self.jerk is not None:
            object.__setattr__(self, "jerk", positive_vector(self.jerk, "jerk"))
        for name in ("acceleration", "jerk"):
            value = getattr(self, name)
            if value is not None and value.shape != self.velocity.shape:
                raise ValueError(
                    f"{name} limits have shape {value.shape}, velocity {self.velocity.shape}"
                )
        check_scale(self.speed_scale)

    @property
    def dof(self) -> int:
        return len(self.velocity)

    def scaled(self) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Velocity, acceleration and jerk limits after applying ``speed_scale``."""
        return scale_limits(self.velocity, self.acceleration, self.jerk, self.speed_scale)


def as_vector(values: Sequence[float] | np.ndarray, name: str) -> np.ndarray:
    vector = np.asarray(values, dtype=float).reshape(-1)
    if vector.size == 0 or not np.all(np.isfinite(vector)):
        raise ValueError(f"{name} must be a non-empty finite vector, got {values!r}")
    return vector


def positive_vector(values: Sequence[float] | np.ndarray, name: str) -> np.ndarray:
    vector = as_vector(values, name)
    if np.any(vector <= 0.0):
        raise ValueError(f"{name} must be positive, got {vector.tolist()}")
    return vector


def check_scale(speed_scale: float) -> None:
    if not (np.isfinite(speed_scale) and 0.0 < speed_scale <= 1.0):
        raise ValueError(f"speed_scale must be in (0, 1], got {speed_scale}")


def scale_limits(
    vel: np.ndarray, acc: np.ndarray, jerk: np.ndarray | None, speed_scale: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    check_scale(speed_scale)
    s = float(speed_scale)
    return vel * s, acc * s**2, None if jerk is None else jerk * s**3


def waypoint_array(waypoints: Sequence[Sequence[float]] | np.ndarray) -> np.ndarray:
    points = np.asarray(waypoints, dtype=float)
    if points.ndim != 2 or points.shape[0] < 1 or points.shape[1] < 1:
        raise ValueError(f"waypoints must have shape (K, dof), got {points.shape}")
    if not np.all(np.isfinite(points)):
        raise ValueError("waypoints contain NaN or infinite values")
    return points


def check_dof(points: np.ndarray, *limits: np.ndarray) -> None:
    for limit in limits:
        if limit.shape != (points.shape[1],):
            raise ValueError(
                f"limits have {limit.shape[0]} values, waypoints {points.shape[1]} DoF"
            )


def drop_duplicates(points: np.ndarray) -> np.ndarray:
    keep = [0]
    for index in range(1, len(points)):
        if np.max(np.abs(points[index] - points[keep[-1]])) > DUPLICATE_TOLERANCE:
            keep.append(index)
    if len(keep) > 1 and keep[-1] != len(points) - 1:
        keep[-1] = len(points) - 1  # end exactly on the last waypoint given
    return points[keep]


def resolve_joint_names(joint_names: Sequence[str] | None, dof: int) -> tuple[str, ...]:
    if joint_names is None:
        return tuple(f"joint{i}" for i in range(dof))
    names = tuple(joint_names)
    if len(names) != dof:
        raise ValueError(f"{len(names)} joint names for {dof} DoF")
    return names
