"""Choosing the grasp: the ordered candidates walked through the feasibility test.

The order comes from ``harness.grasps`` (filters, then the reference's weighted draw or the
strict order); each candidate is tested (``pick.test_mode``: ``ik`` or ``forward``,
docs/reference-pick-skill.md section 5) until one passes. What happens when none does (the
reference proceeds with the last one tested, strict stops) is the semantics' call
(``Semantics.fall_back_to_last_tested``).
"""

from __future__ import annotations

import json
from collections import Counter
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
                previous.T_world_pregrasp, previous.T_world_grasp,
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
            verdict.T_world_pregrasp, verdict.T_world_grasp = T_pre, T_grasp
            tested[pose_index] = verdict
        verdicts.append(verdict)
        if verdict.feasible:
            return verdicts, verdict
    return verdicts, None


def candidate_failures(verdicts: list[CandidateVerdict]) -> dict[str, int]:
    """How many distinct tested candidates failed at each stage (``ik_pregrasp``, ``ik_grasp``,
    ``transport``, ``approach``, ``lift``, ``return``), most frequent first.

    A duplicate draw repeats its first answer, so it is counted once (as ``n_feasible`` counts
    feasible candidates): the counts plus ``n_feasible`` make the distinct candidates tested."""
    first: dict[int, CandidateVerdict] = {}
    for verdict in verdicts:
        first.setdefault(verdict.pose_index, verdict)
    counts = Counter(v.stage or "unknown" for v in first.values() if not v.feasible)
    return dict(sorted(counts.items(), key=lambda item: (-item[1], item[0])))


def candidate_failures_json(verdicts: list[CandidateVerdict]) -> str:
    """``candidate_failures`` as the row's JSON object string (``{}`` when none failed)."""
    return json.dumps(candidate_failures(verdicts))


def none_feasible_message(verdicts: list[CandidateVerdict], test_mode: str) -> str:
    """Why no candidate passed: the failures per stage over the distinct candidates tested,
    and the last candidate's own reason (the one the reference would proceed with)."""
    if not verdicts:
        return f"no candidate to run through the {test_mode} test"
    counts = candidate_failures(verdicts)
    distinct = len({v.pose_index for v in verdicts})
    stages = ", ".join(f"{stage} {count}" for stage, count in counts.items())
    last = verdicts[-1]
    return (
        f"none of the {len(verdicts)} candidates ({distinct} distinct) passed the {test_mode} "
        f"test; failures by stage: {stages}; last: {last.stage}: {last.detail}"
    )
