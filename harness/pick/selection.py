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

from harness.planning.plans import CandidateVerdict

# Test one candidate: (position in the order, pose index, score) -> its verdict.
CandidateTest = Callable[[int, int, float], CandidateVerdict]


def walk_candidates(
    indices: list[int],
    scores: list[float],
    test: CandidateTest,
    known: dict[int, CandidateVerdict] | None = None,
) -> tuple[list[CandidateVerdict], CandidateVerdict | None]:
    """Walk the ordered candidates until one passes; (verdicts, chosen).

    ``test`` runs the feasibility test (``pick.test_mode``) of one candidate. ``known`` holds
    the verdicts already found for this scene and seed, by pose index, and receives the new
    ones: a candidate's verdict depends only on (task physics, seed, candidate)
    (``harness.episode.streams``), so a known one is reused instead of re-tested. That covers
    duplicates too: the reference draws with replacement, re-tests and gets the same answer.
    A reused verdict takes its position in this order and no test time.
    """
    memory: dict[int, CandidateVerdict] = {} if known is None else known
    verdicts: list[CandidateVerdict] = []
    for position, pose_index in enumerate(indices):
        score = float(scores[position])
        previous = memory.get(pose_index)
        if previous is not None:
            verdict = CandidateVerdict(
                position, pose_index, score, previous.feasible, previous.stage, previous.detail,
                previous.ik_pregrasp, previous.ik_grasp, previous.plan, 0.0,
                previous.T_world_pregrasp, previous.T_world_grasp,
            )  # fmt: skip
        else:
            verdict = test(position, pose_index, score)
            memory[pose_index] = verdict
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
