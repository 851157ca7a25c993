"""Plans and verdicts: what testing and planning one grasp candidate produce.

``ChainPlan`` is the executed motion (transport, approach, lift, return) in joint waypoints,
``CandidateVerdict`` the outcome of testing one candidate, ``Selection`` the chosen candidate.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from harness.planning.ik import IKResult


@dataclass
class ChainPlan:
    """Joint waypoints (active joints) of one candidate's executed motion, and its targets."""

    transport: np.ndarray  # (K, n) current -> pre-grasp
    approach: np.ndarray  # (K, n) pre-grasp -> grasp (Cartesian straight line)
    lift: np.ndarray | None  # (K, n) grasp -> lifted (Cartesian), None without a lift
    retreat: np.ndarray | None  # (K, n) lifted -> pre-grasp, with return_to_pregrasp
    T_world_pregrasp: np.ndarray
    T_world_grasp: np.ndarray
    T_world_lift: np.ndarray | None
    used_rrt: bool = False


@dataclass(frozen=True)
class FailurePoint:
    """Where a candidate's test failed, for viewers and the row: the active-joint configuration
    that failed (the best IK attempt for an unreachable target, the colliding configuration
    for a collision) and the first colliding pair of bodies (None when no collision)."""

    q: np.ndarray | None
    pair: tuple[str, str] | None = None
    # For an unreachable target: the joint of ``q`` at (within ``LIMIT_MARGIN`` of) a position
    # limit, as ``name:lower`` / ``name:upper`` ('' when none is), and the IK residual there.
    limit_joint: str = ""
    residual_m: float | None = None
    residual_rad: float | None = None
    # What limits the reach (``harness.planning.reach``): joint_limit, lift_height, collision,
    # beyond_reach or unconverged; '' for a failure that is neither reach nor collision.
    reach_limit: str = ""


@dataclass
class CandidateVerdict:
    """Outcome of testing one candidate (one entry of the ordered candidate list)."""

    position: int  # position in the candidate list
    pose_index: int  # index into the 2N EE poses
    score: float
    feasible: bool
    stage: str  # "" when feasible, else where it failed (ik_pregrasp, transport, ...)
    detail: str = ""
    ik_pregrasp: IKResult | None = None
    ik_grasp: IKResult | None = None
    plan: ChainPlan | None = None
    time_s: float = 0.0
    # The world poses the candidate was tested at (set by the candidate walk, for viewers).
    T_world_pregrasp: np.ndarray | None = None
    T_world_grasp: np.ndarray | None = None
    failure_point: FailurePoint | None = None  # set when the test failed


@dataclass
class Selection:
    """The candidate chosen for execution and how the choice was made."""

    chosen: CandidateVerdict | None
    verdicts: list[CandidateVerdict]
    outcome: Literal["feasible", "fallback_last", "none"]
    ik_time_s: float
    plan_time_s: float

    @property
    def n_feasible(self) -> int:
        return sum(v.feasible for v in self.verdicts)
