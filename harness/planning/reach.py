"""What limits an unreachable target: the row's ``reach_limit`` (issue 55).

Read from the best IK attempt's final state ``q`` (the configuration the row's
``ik_residual_mm`` is measured at), first cause wins:

- ``joint_limit``: a joint lies at a position limit there (``limit_joint`` names it);
- ``lift_height``: the lift is held (the reference's pick holds it at its home) and the same
  target is reached once the lift may move within its range: the held height is what the arm
  lacks;
- ``beyond_reach``: no joint at a limit, and the target lies farther from the arm's shoulder
  (the origin of the link its second joint moves) than the end effector got, with the
  remaining error pointing away from the shoulder (cosine ``OUTWARD_COSINE`` or more): the arm
  stretched towards the target and stopped at its workspace boundary;
- ``unconverged``: none of these (the target lies within the distance the arm reached, or the
  error is not outward: the solver stopped in the workspace).

A failure at a collision (every IK solution found collides) is ``collision``; a failure that is
not about reach (a path, a joint jump) leaves the column ''.

Why not the Jacobian's conditioning: on the R5a, 70% of uniformly random in-limit
configurations have a smallest-to-largest singular value ratio below 0.04 (the three parallel
pitch joints J2-J4), so a conditioning threshold does not tell a stopped reach from any other
configuration; the distance test does (tests/test_reach_limit.py).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Literal

import numpy as np

from harness.planning.ik import WholeBodyIK

ReachLimit = Literal["joint_limit", "lift_height", "collision", "beyond_reach", "unconverged"]
REACH_LIMITS: tuple[ReachLimit, ...] = (
    "joint_limit",
    "lift_height",
    "collision",
    "beyond_reach",
    "unconverged",
)
OUTWARD_COSINE = 0.7  # the residual within ~45 degrees of the shoulder-to-target direction


def outward(
    ik: WholeBodyIK, q: np.ndarray, T_world_target: np.ndarray, shoulder_frame: str
) -> tuple[float, float, float]:
    """(target's distance from the shoulder, the end effector's at ``q`` (m), cosine between the
    remaining position error and the shoulder-to-target direction)."""
    shoulder = ik.fk(q, shoulder_frame)[:3, 3]
    ee = ik.fk(q)[:3, 3]
    target = np.asarray(T_world_target, dtype=float)[:3, 3]
    error = target - ee
    radial = target - shoulder
    d_target, d_ee = float(np.linalg.norm(radial)), float(np.linalg.norm(ee - shoulder))
    norm = float(np.linalg.norm(error)) * d_target
    cosine = float(error @ radial) / norm if norm > 0 else 0.0
    return d_target, d_ee, cosine


def classify_reach(
    ik: WholeBodyIK,
    q: np.ndarray,
    T_world_target: np.ndarray,
    limit_joint: str,
    shoulder_frame: str,
    reaches_with_free_lift: Callable[[], bool] | None,
) -> ReachLimit:
    """The ``reach_limit`` of an unreachable target's best IK attempt ``q`` (module doc).
    ``reaches_with_free_lift`` solves the target again with the lift free (None where no lift
    is held)."""
    if limit_joint:
        return "joint_limit"
    if reaches_with_free_lift is not None and reaches_with_free_lift():
        return "lift_height"
    d_target, d_ee, cosine = outward(ik, q, T_world_target, shoulder_frame)
    if d_target > d_ee and cosine >= OUTWARD_COSINE:
        return "beyond_reach"
    return "unconverged"
