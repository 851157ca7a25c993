"""Candidate order (docs/reference-pick-skill.md sections 4.4, 4.5): which poses the feasibility
loop walks.

:func:`reference_order` (the reference's weighted draw) or :func:`strict_order` (unique passing
candidates) -> :class:`CandidateOrder`; :func:`order_candidates` picks one by semantics.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from harness.grasps.arrays import FloatArray
from harness.grasps.race import draw_with_replacement, draw_without_replacement, race_key

CANDIDATE_BATCH = 20  # the reference's CUROBO_BATCH_SIZE (sample_ee_pose max_length)
SCORE_EPSILON = 1e-8  # weights are 1 / (score + 1e-8)
Outcome = Literal["ok", "fallback", "filter_empty"]
Semantics = Literal["reference", "strict"]


@dataclass(frozen=True, eq=False)
class CandidateOrder:
    """The candidates the feasibility loop walks, in order, as indices into the 2N poses.

    ``top_candidates`` is the deterministic list before any random draw (the top by
    (score, index)), or the fallback list. ``outcome`` is ``ok``, ``fallback`` (reference: nothing
    passed, rows 0..19 unfiltered) or ``filter_empty`` (no candidates at all; ``note`` says why).
    """

    indices: np.ndarray
    scores: np.ndarray
    outcome: Outcome
    top_candidates: np.ndarray
    semantics: Semantics
    note: str = ""

    def __len__(self) -> int:
        return int(self.indices.shape[0])


def _sort_by_score(scores: FloatArray, indices: np.ndarray) -> np.ndarray:
    """``indices`` sorted by (score, index), ascending, as the reference's tuple sort."""
    return indices[np.lexsort((indices, scores[indices]))]


def top_by_score(scores: FloatArray, indices: np.ndarray, k: int) -> np.ndarray:
    """The first ``k`` of ``indices`` by (score, index), in that order, without a full sort.

    ``indices`` must be ascending (e.g. from ``np.flatnonzero``), so among equal scores the
    earliest indices win, as in the reference.
    """
    indices = np.asarray(indices, dtype=np.int64)
    if indices.shape[0] <= k:
        return _sort_by_score(scores, indices)
    candidate_scores = scores[indices]
    kth = np.partition(candidate_scores, k - 1)[k - 1]
    below = indices[candidate_scores < kth]
    tied = indices[candidate_scores == kth][: k - below.shape[0]]
    return _sort_by_score(scores, np.concatenate([below, tied]))


def _weights(scores: FloatArray) -> FloatArray:
    weights = 1.0 / (scores + SCORE_EPSILON)
    return weights / weights.sum()


def reference_order(
    scores: FloatArray,
    combined: np.ndarray,
    rng: np.random.Generator,
    max_candidates: int = CANDIDATE_BATCH,
) -> CandidateOrder:
    """The reference's ``sample_ee_pose``: top 20, 20 weighted draws with replacement, sorted.

    The draws have the reference's law (weights 1/score); the numbers come from an exponential
    race keyed by pose index (``harness.grasps.race``) instead of ``random.choices``.

    When nothing passes, the candidates are poses 0..19 of the unfiltered array in index order
    (``fallback``); with fewer than 20 poses the reference would raise IndexError there, which is
    reported as ``filter_empty`` instead.
    """
    scores = np.asarray(scores, dtype=np.float64)
    passing = np.flatnonzero(combined)
    total = scores.shape[0]
    if passing.shape[0] == 0:
        if total < max_candidates:
            return CandidateOrder(
                indices=np.empty(0, dtype=np.int64),
                scores=np.empty(0),
                outcome="filter_empty",
                top_candidates=np.empty(0, dtype=np.int64),
                semantics="reference",
                note=f"no pose passed the filters and the reference fallback (poses "
                f"0..{max_candidates - 1}) is out of range for {total} poses: IndexError there",
            )
        fallback = np.arange(max_candidates, dtype=np.int64)
        return CandidateOrder(
            indices=fallback,
            scores=scores[fallback],
            outcome="fallback",
            top_candidates=fallback.copy(),
            semantics="reference",
            note="no pose passed the filters; reference fallback to poses "
            f"0..{max_candidates - 1} of the unfiltered array",
        )
    top = top_by_score(scores, passing, max_candidates)
    # Each draw is an exponential race keyed by the global pose index (harness.grasps.race):
    # the reference's law, coupled across filter settings of the same seed.
    drawn = draw_with_replacement(race_key(rng), top, _weights(scores[top]), max_candidates)
    drawn = _sort_by_score(scores, drawn)
    return CandidateOrder(
        indices=drawn,
        scores=scores[drawn],
        outcome="ok",
        top_candidates=top,
        semantics="reference",
    )


def strict_order(
    scores: FloatArray,
    combined: np.ndarray,
    rng: np.random.Generator | None = None,
    max_candidates: int = CANDIDATE_BATCH,
    sample: bool = False,
) -> CandidateOrder:
    """Strict semantics: unique passing candidates by (score, index); nothing passing is final.

    With ``sample`` the ``max_candidates`` are drawn without replacement from all passing poses
    with weights 1/score (no index bias), then sorted by (score, index). ``top_candidates`` is
    always the deterministic top by (score, index).
    """
    scores = np.asarray(scores, dtype=np.float64)
    passing = np.flatnonzero(combined)
    if passing.shape[0] == 0:
        empty = np.empty(0, dtype=np.int64)
        return CandidateOrder(
            indices=empty,
            scores=np.empty(0),
            outcome="filter_empty",
            top_candidates=empty.copy(),
            semantics="strict",
            note="no pose passed the filters",
        )
    top = top_by_score(scores, passing, max_candidates)
    chosen = top
    if sample:
        if rng is None:
            raise ValueError("strict sampling needs a numpy Generator")
        count = min(max_candidates, passing.shape[0])
        drawn = draw_without_replacement(race_key(rng), passing, _weights(scores[passing]), count)
        chosen = _sort_by_score(scores, np.asarray(drawn, dtype=np.int64))
    return CandidateOrder(
        indices=chosen,
        scores=scores[chosen],
        outcome="ok",
        top_candidates=top,
        semantics="strict",
    )


def order_candidates(
    scores: FloatArray,
    combined: np.ndarray,
    semantics: Semantics,
    rng: np.random.Generator,
    max_candidates: int = CANDIDATE_BATCH,
    strict_sampling: bool = False,
) -> CandidateOrder:
    """:func:`reference_order` or :func:`strict_order` by ``semantics``."""
    if semantics == "reference":
        return reference_order(scores, combined, rng, max_candidates)
    if semantics == "strict":
        return strict_order(scores, combined, rng, max_candidates, sample=strict_sampling)
    raise ValueError(f"semantics must be 'reference' or 'strict', got {semantics!r}")
