"""Choosing the grasp: the ordered candidates walked through the feasibility test.

The order comes from ``harness.grasps`` (filters, then the reference's weighted draw or the
strict order); each candidate is tested (``pick.test_mode``: ``ik`` or ``forward``,
docs/reference-pick-skill.md section 5) until one passes. What happens when none does (the
reference proceeds with the last one tested, strict stops) is the semantics' call
(``Semantics.fall_back_to_last_tested``).
"""

from __future__ import annotations

from collections.abc import Callable

from harness.planning.plans import CandidateVerdict

# Test one candidate: (position in the order, pose index, score) -> its verdict.
CandidateTest = Callable[[int, int, float], CandidateVerdict]


def walk_candidates(
    indices: list[int],
    scores: list[float],
    test: CandidateTest,
    known: dict[int, CandidateVerdict] | None = None,
) -> tuple[list[CandidateVerdict], CandidateVerdict | None, int]:
    """Walk the ordered candidates until one passes; (verdicts, chosen, answers reused).

    ``test`` runs the feasibility test (``pick.test_mode``) of one candidate. ``known`` holds
    the verdicts already found for this scene and seed, by pose index, and receives the new
    ones: a candidate's verdict depends only on (task physics, seed, candidate)
    (``harness.episode_streams``), so a known one is reused instead of re-tested. That covers
    duplicates too: the reference draws with replacement, re-tests and gets the same answer.
    A reused verdict takes its position in this order and no test time.
    """
    memory: dict[int, CandidateVerdict] = {} if known is None else known
    verdicts: list[CandidateVerdict] = []
    reused = 0
    for position, pose_index in enumerate(indices):
        score = float(scores[position])
        previous = memory.get(pose_index)
        if previous is not None:
            reused += 1
            verdict = CandidateVerdict(
                position, pose_index, score, previous.feasible, previous.stage, previous.detail,
                previous.ik_pregrasp, previous.ik_grasp, previous.plan, 0.0,
            )  # fmt: skip
        else:
            verdict = test(position, pose_index, score)
            memory[pose_index] = verdict
        verdicts.append(verdict)
        if verdict.feasible:
            return verdicts, verdict, reused
    return verdicts, None, reused
