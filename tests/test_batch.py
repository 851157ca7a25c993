"""Batch feasibility (``use_batch``): the reference's select_index_by_priority_dual choice."""

from __future__ import annotations

import numpy as np

from harness.pick.batch import batch_walk, prioritized
from harness.planning.ik import IKResult
from harness.planning.plans import CandidateVerdict

Q_NOW = np.zeros(7)


def _ik(offset: float, position_error: float = 0.0, rotation_error: float = 0.0) -> IKResult:
    return IKResult(np.full(7, offset), True, position_error, rotation_error, 1, 0)


def _walk(feasible: list[bool], grasps: list[IKResult | None], seed: int = 0):
    tested: list[int] = []

    def test(position: int, pose_index: int, score: float) -> CandidateVerdict:
        tested.append(position)
        stage = "" if feasible[position] else "ik_pregrasp"
        return CandidateVerdict(position, pose_index, score, feasible[position], stage)

    def grasp_test(position: int) -> tuple[IKResult, bool]:
        ik = grasps[position]
        return (ik, True) if ik is not None else (IKResult(Q_NOW, False, 1.0, 1.0, 1, 0), True)

    n = len(feasible)
    choice = batch_walk(
        list(range(100, 100 + n)), [0.1] * n, Q_NOW, test, grasp_test, np.random.default_rng(seed)
    )
    return choice, tested


def test_prioritized_keeps_errors_at_most_the_mean_then_sorts_by_path_length() -> None:
    grasps = [
        (0, _ik(0.3, 0.001), 2.1),
        (1, _ik(0.1, 0.009), 0.7),  # shortest, but its position error is above the mean
        (2, _ik(0.2, 0.001), 1.4),
    ]
    assert prioritized(grasps) == [2, 0]
    # When none is at most the mean in both errors, every success is ranked by length.
    crossed = [(0, _ik(0.1, 0.001, 0.02), 0.7), (1, _ik(0.2, 0.003, 0.0), 1.4)]
    assert prioritized(crossed) == [0, 1]
    assert prioritized([]) == []


def test_batch_tests_every_candidate_and_takes_the_shortest_feasible_grasp() -> None:
    # Candidate 0 is feasible but its grasp is far; 2 is feasible and nearest; 1 is nearer
    # still but its pre-grasp fails.
    choice, tested = _walk([True, False, True, False], [_ik(0.5), _ik(0.05), _ik(0.1), None])
    assert tested == [0, 1, 2, 3]  # no early stop, unlike the sequential walk
    assert (choice.picked.position, choice.rule) == (2, "both")


def test_batch_falls_back_to_a_random_grasp_success_then_to_index_0() -> None:
    picks = {
        _walk([False, False, False], [None, _ik(0.2), _ik(0.1)], seed)[0].picked.position
        for seed in range(20)
    }
    assert picks == {1, 2}  # random.choice over the grasp successes ("only final success")
    choice, _ = _walk([False, False, False], [None, _ik(0.2), _ik(0.1)])
    assert choice.rule == "grasp_only" and not choice.picked.feasible
    choice, _ = _walk([False, False], [None, None])
    assert (choice.picked.position, choice.rule) == (0, "first")


def test_a_duplicate_draw_repeats_its_first_verdict() -> None:
    calls: list[int] = []

    def test(position: int, pose_index: int, score: float) -> CandidateVerdict:
        calls.append(pose_index)
        return CandidateVerdict(position, pose_index, score, True, "")

    choice = batch_walk(
        [7, 7, 8], [0.1, 0.1, 0.2], Q_NOW, test, lambda p: (_ik(0.1 * (p + 1)), True),
        np.random.default_rng(0),
    )  # fmt: skip
    assert calls == [7, 8]
    assert [v.position for v in choice.verdicts] == [0, 1, 2]
    assert choice.picked.position == 0
