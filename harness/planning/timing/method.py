"""The timing method of a pick (``pick.timing``): TOPP-RA or Ruckig, chosen by name."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import numpy as np

from harness.planning.timing.inputs import TimingLimits
from harness.planning.timing.ruckig_moves import ruckig_through
from harness.planning.timing.toppra_path import time_parameterize_toppra
from harness.planning.timing.trajectory import Trajectory

TimingMethod = Literal["toppra", "ruckig"]


def plan_timing(
    waypoints: Sequence[Sequence[float]] | np.ndarray,
    limits: TimingLimits,
    method: TimingMethod = "toppra",
    joint_names: Sequence[str] | None = None,
    label: str = "",
    gridpoints: int | None = None,
) -> Trajectory:
    """Time ``waypoints`` with the method named by ``pick.timing`` (``toppra`` | ``ruckig``)."""
    if method == "toppra":
        return time_parameterize_toppra(
            waypoints,
            limits.velocity,
            limits.acceleration,
            limits.speed_scale,
            gridpoints=gridpoints,
            joint_names=joint_names,
            label=label,
        )
    if method == "ruckig":
        if limits.jerk is None:
            raise ValueError("timing 'ruckig' needs jerk limits")
        return ruckig_through(
            waypoints,
            limits.velocity,
            limits.acceleration,
            limits.jerk,
            limits.speed_scale,
            joint_names=joint_names,
            label=label,
        )
    raise ValueError(f"unknown timing method {method!r}; expected 'toppra' or 'ruckig'")
