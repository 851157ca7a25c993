"""Batch feasibility: the reference's ``use_batch`` candidate choice (its Genie1 tasks).

With ``use_batch`` the reference's pick (core/skills/pick.py 101-113) plans to all the candidates
at once, once to the pre-grasps and once to the grasps (cuRobo ``plan_batch``), and executes the
index ``select_index_by_priority_dual`` (core/utils/plan_utils.py 117-191) returns:

1. the grasp successes, kept where both their position and rotation errors are at most the
   mean over the successes (all of them when that keeps none), ordered by joint path length
   Σ|Δq| (``sort_by_difference_js``, unweighted here);
2. the first of those whose pre-grasp also succeeded;
3. else a random one of those (``random.choice``: "only final success");
4. else index 0.

When the pre-grasps equal the grasps (``pre_grasp_offset`` 0) it plans once and takes the first
of step 1, else 0 (``select_index_by_priority_single``), which the same rule gives.

Here every candidate is tested with the pick's own test (``test_mode``, the sequential mode's:
pre-grasp, approach, grasp), and each grasp is solved once more from the current state on its own
(collision-checked IK) for its success, errors and the joint line's length to it: the
harness's stand-in for the batch plan to the grasp. Steps 3 and 4 pick a candidate whose test
failed; the reference executes it and fails there, the harness falls back to it as the
semantics says (``Semantics.fall_back_to_last_tested``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from harness.planning.ik import IKResult
from harness.planning.plans import CandidateVerdict

# Test one candidate: (position in the order, pose index, score) -> its verdict.
CandidateTest = Callable[[int, int, float], CandidateVerdict]
# Solve one candidate's grasp alone from the current state: (position) -> (IK, collision-free).
GraspTest = Callable[[int], tuple[IKResult, bool]]


@dataclass(frozen=True)
class BatchChoice:
    """The batch test's verdicts (one per candidate, in order), the verdict the priority rule
    picks, and which rule picked it (``both``, ``grasp_only``, ``first``)."""

    verdicts: list[CandidateVerdict]
    picked: CandidateVerdict
    rule: str


def prioritized(grasps: list[tuple[int, IKResult, float]]) -> list[int]:
    """Positions of the grasp successes in the reference's priority order: errors at most the
    mean (position and rotation; all when none passes), then ascending path length (stable)."""
    if not grasps:
        return []
    position = np.array([ik.position_error for _, ik, _ in grasps])
    rotation = np.array([ik.orientation_error for _, ik, _ in grasps])
    keep = (position <= position.mean()) & (rotation <= rotation.mean())
    kept = [g for g, k in zip(grasps, keep, strict=True) if k] or grasps
    order = np.argsort([length for _, _, length in kept], kind="stable")
    return [kept[i][0] for i in order]


def batch_walk(
    indices: list[int],
    scores: list[float],
    q_now: np.ndarray,
    test: CandidateTest,
    grasp_test: GraspTest,
    rng: np.random.Generator,
    known: dict[int, CandidateVerdict] | None = None,
) -> BatchChoice:
    """Test every candidate and choose as ``select_index_by_priority_dual`` does.

    ``known`` holds verdicts by pose index (a duplicate draw repeats its first answer, as in
    the reference's batch, which plans each copy to the same answer)."""
    memory: dict[int, CandidateVerdict] = {} if known is None else known
    verdicts: list[CandidateVerdict] = []
    grasps: list[tuple[int, IKResult, float]] = []
    solved: dict[int, tuple[IKResult, bool]] = {}
    for position, pose_index in enumerate(indices):
        score = float(scores[position])
        previous = memory.get(pose_index)
        if previous is not None:
            verdict = CandidateVerdict(
                position, pose_index, score, previous.feasible, previous.stage, previous.detail,
                previous.ik_pregrasp, previous.ik_grasp, previous.plan, 0.0,
                previous.T_world_pregrasp, previous.T_world_grasp,
                previous.failure_point,
            )  # fmt: skip
        else:
            verdict = test(position, pose_index, score)
            memory[pose_index] = verdict
        verdicts.append(verdict)
        if pose_index not in solved:
            solved[pose_index] = grasp_test(position)
        ik, free = solved[pose_index]
        if not (ik.success and free) and verdict.feasible and verdict.ik_grasp is not None:
            ik, free = verdict.ik_grasp, True  # reached through its pre-grasp: a success too
        if ik.success and free:
            length = float(np.abs(ik.q - q_now).sum())
            grasps.append((position, ik, length))
    ranked = prioritized(grasps)
    for position in ranked:
        if verdicts[position].feasible:
            return BatchChoice(verdicts, verdicts[position], "both")
    if ranked:
        return BatchChoice(verdicts, verdicts[int(rng.choice(ranked))], "grasp_only")
    return BatchChoice(verdicts, verdicts[0], "first")
