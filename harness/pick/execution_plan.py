"""The motion executed for the chosen candidate: the tested plan when it can be reused, else
planned now (with retries for randomised failures).

A ``forward`` test already planned the chosen candidate's motion; it is executed as is unless
``fixed_orientation`` was applied only after the test (the reference, quirk 13: the executed
motion is re-planned to the new orientation) or the test left the carry out
(``Semantics.test_carry``; the carry is then planned now). An ``ik`` test plans nothing, so the
whole chain is planned here. A failure is ``PlanFailedError`` (the episode's ``plan_failed``).
"""

from __future__ import annotations

import numpy as np

from harness.config import PickConfig
from harness.pick.semantics import Semantics
from harness.pick.targets import CandidatePoses
from harness.planning.planner import PickPlanner
from harness.planning.plans import CandidateVerdict, ChainPlan, FailurePoint

PLAN_RETRIES = 2  # extra attempts for a randomised (RRT / restart) plan failure


class PlanFailedError(Exception):
    """The chosen candidate's motion could not be planned; the message is ``stage: detail``.

    ``stage`` is where it failed (ik_pregrasp, transport, approach, lift, return) and ``point``
    the configuration that failed there (for the row's colliding pair and for viewers)."""

    def __init__(self, stage: str, detail: str, point: FailurePoint | None) -> None:
        super().__init__(f"{stage}: {detail}")
        self.stage = stage
        self.point = point


def plan_chosen(
    planner: PickPlanner,
    pick: PickConfig,
    semantics: Semantics,
    poses: CandidatePoses,
    chosen: CandidateVerdict,
    T_base_grasp: np.ndarray,
    q_now: np.ndarray,
    rng: np.random.Generator,
) -> ChainPlan:
    """Reuse a feasible forward plan, else plan now (fixed_orientation is applied after the test
    in the reference, so the executed motion is re-planned)."""
    T_pre, T_grasp, T_lift = poses.world(T_base_grasp, True)
    reuse = poses.fixed_rotation is None or semantics.fixed_orientation_in_test
    plan: ChainPlan | None = chosen.plan if reuse else None
    attempts = 0
    failure = chosen
    if (
        plan is not None
        and not semantics.test_carry
        and (T_lift is not None or pick.return_to_pregrasp)
    ):
        # A forward test without the carry: the chosen plan ends at the grasp; plan it now.
        plan, stage, why = planner.plan_carry(
            plan, T_lift, pick.return_to_pregrasp, semantics.lift_path, rng
        )
        if plan is None:
            raise PlanFailedError(stage, why, planner.last_failure)
    while plan is None and attempts <= PLAN_RETRIES:
        attempts += 1
        tested = chosen.ik_pregrasp
        failure = planner.plan_chain(
            chosen.position, chosen.pose_index, chosen.score, q_now, T_pre, T_grasp, T_lift,
            pick.return_to_pregrasp, rng,
            pregrasp_seed=tested.q if tested is not None and tested.success else None,
            lift_path=semantics.lift_path,
        )  # fmt: skip
        plan = failure.plan
        if failure.stage not in ("transport", "ik_pregrasp"):
            break  # deterministic failures do not change on a retry
    if plan is None:
        raise PlanFailedError(failure.stage, failure.detail, failure.failure_point)
    return plan
