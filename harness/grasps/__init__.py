"""Grasp core: GraspNet-style annotations -> end-effector poses -> direction filters -> order.

Implements the reference Pick skill's pose post-processing and candidate selection
(docs/reference-pick-skill.md sections 2-4, 11, 12) as vectorised numpy, with no Python
loop over grasps:

- :class:`GraspSet` / :func:`load_grasp_file` (``grasp_set``): a validated N x 17 grasp file;
- :func:`post_process` -> :class:`EEPoses` (``ee_poses``): the 2N poses ``T_obj_ee`` for a robot's
  :class:`GripperConvention` (``conventions``; N grasps plus their 180-degree flips);
- :func:`filter_poses` / :func:`filter_ee_poses` -> :class:`FilterResult` (``filters``): the
  direction filters and ``direction_to_obj`` in the arm base frame, every mask kept;
- :func:`resolve_filters` / :func:`neutral_form` (``filters``): robot-neutral ``approach_filter``
  / ``facing_filter`` <-> per-axis ``filter_{x,y,z}_dir``;
- :func:`reference_order` / :func:`strict_order` -> :class:`CandidateOrder` (``candidates``);
- :func:`select_candidates` -> :class:`CandidateSelection` (``selection``): all of it for one pick;

This package only re-exports; its modules import each other directly.
"""

from harness.grasps.candidates import (
    CANDIDATE_BATCH,
    CandidateOrder,
    order_candidates,
    reference_order,
    strict_order,
    top_by_score,
)
from harness.grasps.conventions import AXES, GripperConvention
from harness.grasps.ee_poses import EEPoses, base_frame_poses, ee_poses_for_pick, post_process
from harness.grasps.filters import (
    FilterResult,
    check_strict_filters,
    filter_ee_poses,
    filter_poses,
    neutral_form,
    resolve_filter_sources,
    resolve_filters,
)
from harness.grasps.grasp_set import GraspSet, load_grasp_file
from harness.grasps.selection import CandidateRule, CandidateSelection, select_candidates

__all__ = [
    "AXES",
    "CANDIDATE_BATCH",
    "CandidateOrder",
    "CandidateRule",
    "CandidateSelection",
    "EEPoses",
    "FilterResult",
    "GraspSet",
    "GripperConvention",
    "base_frame_poses",
    "check_strict_filters",
    "ee_poses_for_pick",
    "filter_ee_poses",
    "filter_poses",
    "load_grasp_file",
    "neutral_form",
    "order_candidates",
    "post_process",
    "reference_order",
    "resolve_filter_sources",
    "resolve_filters",
    "select_candidates",
    "strict_order",
    "top_by_score",
]
