"""Choosing the grasp: the ordered candidates walked through the feasibility test.

The order comes from ``harness.grasps`` (filters, then the reference's weighted draw or the
strict order); each candidate is tested (``pick.test_mode``: ``ik`` or ``forward``,
docs/reference-pick-skill.md section 5) until one passes. What happens when none does (the
reference proceeds with the last one tested, strict stops) is the semantics' call
(``Semantics.fall_back_to_last_tested``).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from harness.config import PickConfig
from harness.planning.planner import PickPlanner
from harness.planning.plans import CandidateVerdict


def walk_candidates(
    planner: PickPlanner,
    pick: PickConfig,
    indices: list[int],
    scores: list[float],
    targets_of: Callable[[int], tuple[np.ndarray, np.ndarray, np.ndarray | None]],
    q_now: np.ndarray,
    rng: np.random.Generator,
    return_to_pregrasp: bool = False,
) -> tuple[list[CandidateVerdict], CandidateVerdict | None]:
    """Walk the ordered candidates until one passes ``pick.test_mode``; (verdicts, chosen).

    ``targets_of(position)`` gives the world pre-grasp, grasp and lift poses of a candidate
    (the lift None when the test plans none); a ``forward`` test plans the return to the
    pre-grasp only with ``return_to_pregrasp``.
    A duplicate (the reference draws with replacement) reuses the first answer: the reference
    re-tests it and gets the same one.
    """
    tested: dict[int, CandidateVerdict] = {}
    verdicts: list[CandidateVerdict] = []
    for position, pose_index in enumerate(indices):
        score = float(scores[position])
        if pose_index in tested:
            previous = tested[pose_index]
            verdict = CandidateVerdict(
                position, pose_index, score, previous.feasible, previous.stage, previous.detail,
                previous.ik_pregrasp, previous.ik_grasp, previous.plan, 0.0,
            )  # fmt: skip
        else:
            T_pre, T_grasp, T_lift = targets_of(position)
            if pick.test_mode == "ik":
                verdict = planner.test_ik(
                    position, pose_index, score, q_now, T_pre, T_grasp,
                    pick.pre_grasp_offset > 0, rng,
                )  # fmt: skip
            else:
                verdict = planner.plan_chain(
                    position, pose_index, score, q_now, T_pre, T_grasp, T_lift,
                    return_to_pregrasp, rng,
                )  # fmt: skip
            tested[pose_index] = verdict
        verdicts.append(verdict)
        if verdict.feasible:
            return verdicts, verdict
    return verdicts, None
