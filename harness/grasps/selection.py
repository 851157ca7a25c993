"""One entry point for the episode code: filters and candidate order of one pick's grasps.

:func:`select_candidates` -> :class:`CandidateSelection`: resolve the pick's filters for the robot,
apply them in the arm base frame, order the candidates.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike

from harness.config import AxisFilter, PickConfig
from harness.grasps.arrays import FloatArray
from harness.grasps.candidates import CANDIDATE_BATCH, CandidateOrder, Semantics, order_candidates
from harness.grasps.conventions import GripperConvention
from harness.grasps.ee_poses import EEPoses, base_frame_poses
from harness.grasps.filters import (
    FilterResult,
    check_strict_filters,
    filter_ee_poses,
    resolve_filter_sources,
    resolve_filters,
)


@dataclass(frozen=True, eq=False)
class CandidateSelection:
    """Filters and order of one pick's grasps for one object pose in the arm base frame."""

    ee_poses: EEPoses
    T_base_obj: FloatArray
    filters: dict[str, AxisFilter]
    filter_sources: dict[str, str]
    filter_result: FilterResult
    order: CandidateOrder

    @cached_property
    def T_base_ee(self) -> FloatArray:
        """All 2N poses in the arm base frame, ``(2N, 4, 4)`` (computed on first access)."""
        return base_frame_poses(self.ee_poses, self.T_base_obj)

    def T_base_ee_at(self, indices: ArrayLike) -> FloatArray:
        """Base-frame transforms ``(k, 4, 4)`` of the poses at ``indices``."""
        return np.matmul(self.T_base_obj, self.ee_poses.T_obj_ee_at(indices))

    @property
    def candidate_T_base_ee(self) -> FloatArray:
        """Base-frame transforms of the ordered candidates, ``(len(order), 4, 4)``."""
        return self.T_base_ee_at(self.order.indices)

    def counts(self) -> dict[str, int]:
        """``total`` poses, ``grasps``, ``passed`` and one ``passed_<key>`` per active filter."""
        out = {
            "grasps": self.ee_poses.n_grasps,
            "total": self.filter_result.total,
            "passed": self.filter_result.passed,
        }
        out.update({f"passed_{k}": v for k, v in self.filter_result.counts().items()})
        return out


@dataclass(frozen=True)
class CandidateRule:
    """How a pick's semantics choose candidates (built by ``harness.pick.semantics.Semantics``).

    ``order``: the reference's weighted draw with replacement or strict's ranked order.
    ``reject_impossible_filters``: a filter that can never pass is a ConfigError (strict).
    """

    order: Semantics
    reject_impossible_filters: bool


def select_candidates(
    ee_poses: EEPoses,
    convention: GripperConvention,
    pick: PickConfig,
    T_base_obj: ArrayLike,
    rng: np.random.Generator,
    rule: CandidateRule,
    *,
    max_candidates: int = CANDIDATE_BATCH,
    strict_sampling: bool | None = None,
) -> CandidateSelection:
    """Resolve the pick's filters for this robot, apply them in the arm base frame, order.

    ``T_base_obj`` is the object pose in the arm base frame at selection time. Randomness comes
    only from ``rng``. ``rule`` is the semantics' candidate rule (``Semantics.candidates``):
    the order, and whether a filter that can never pass is a ConfigError.
    """
    T_bo = np.asarray(T_base_obj, dtype=np.float64)
    if T_bo.shape != (4, 4):
        raise ValueError(f"T_base_obj must be a 4x4 transform, got shape {T_bo.shape}")
    filters = resolve_filters(pick, convention)
    if rule.reject_impossible_filters:
        check_strict_filters(filters)
    result = filter_ee_poses(ee_poses, T_bo, filters, pick.direction_to_obj)
    if strict_sampling is None:
        strict_sampling = pick.strict_sampling
    order = order_candidates(
        ee_poses.scores, result.combined, rule.order, rng, max_candidates, strict_sampling
    )
    return CandidateSelection(
        ee_poses=ee_poses,
        T_base_obj=T_bo,
        filters=filters,
        filter_sources=resolve_filter_sources(pick, convention),
        filter_result=result,
        order=order,
    )
