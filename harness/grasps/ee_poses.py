"""End-effector poses (docs/reference-pick-skill.md section 3): grasps -> the 2N poses ``T_obj_ee``
of a robot.

:func:`post_process` -> :class:`EEPoses`: the N grasps for a robot's :class:`GripperConvention`
plus their 180-degree flips, computed without a Python loop over grasps.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike

from harness.config import PickConfig
from harness.grasps.arrays import FloatArray, read_only
from harness.grasps.conventions import AXES, GripperConvention
from harness.grasps.grasp_set import GraspSet
from harness.transforms import make_T

# Right-multiplied onto R_obj_ee: a 180-degree turn about the approach axis (step 7).
FLIP_DIAGONALS: dict[str, FloatArray] = {
    "x": read_only(np.array([1.0, -1.0, -1.0])),
    "y": read_only(np.array([-1.0, 1.0, -1.0])),
    "z": read_only(np.array([-1.0, -1.0, 1.0])),
}

Constraints = tuple[str, float, float]


@dataclass(frozen=True, eq=False)
class EEPoses:
    """2N end-effector poses ``T_obj_ee`` in the object frame, as the reference builds them.

    Poses ``0..N-1`` are the post-processed grasps (after ``constraints``), poses ``N..2N-1`` the
    same grasps turned 180 degrees about the approach axis (fingers swapped): pose i and pose
    N + i are one physical grasp. Only the N grasps are stored (``grasp_*`` fields); the 2N-long
    arrays (``rotations``, ``positions``, ``scores``, ``source_row``, ``flipped``, ...) are
    derived on first access, which halves the work and memory of post-processing.
    ``source_row`` is the grasp-file row of each pose (``0..N-1`` twice when no constraints
    drop rows); ``tcp_points`` are the scaled grasp points (the TCP targets).
    """

    grasp_rotations: FloatArray  # (N, 3, 3) R_obj_ee of the unflipped poses
    grasp_positions: FloatArray  # (N, 3) p_obj_ee, the EE origin (the same for both halves)
    grasp_scores: FloatArray  # (N,)
    grasp_rows: np.ndarray  # (N,) int64, row in the grasp file
    grasp_tcp_points: FloatArray  # (N, 3)
    grasp_widths: FloatArray  # (N,) clipped to the gripper range
    grasp_depths: FloatArray  # (N,)
    approach_index: int
    flip_diagonal: FloatArray  # (3,) the flipped half is grasp_rotations @ diag(flip_diagonal)
    tcp_offset: float
    grasp_scale: float
    source: str = ""

    def __len__(self) -> int:
        return 2 * self.n_grasps

    @property
    def n_grasps(self) -> int:
        """Number of grasps kept by post-processing (half the number of poses)."""
        return int(self.grasp_scores.shape[0])

    def grasp_index(self, indices: ArrayLike) -> np.ndarray:
        """The grasp (0..N-1) of each pose index: pose i and pose N + i share grasp i."""
        return np.asarray(indices, dtype=np.int64) % max(self.n_grasps, 1)

    def _twice(self, values: np.ndarray) -> np.ndarray:
        return read_only(np.concatenate([values, values]))

    @cached_property
    def rotations(self) -> FloatArray:
        """``R_obj_ee`` of all 2N poses, ``(2N, 3, 3)``."""
        flipped = self.grasp_rotations * self.flip_diagonal
        return read_only(np.concatenate([self.grasp_rotations, flipped]))

    @cached_property
    def positions(self) -> FloatArray:
        """EE origins ``p_obj_ee`` of all 2N poses, ``(2N, 3)``."""
        return self._twice(self.grasp_positions)

    @cached_property
    def scores(self) -> FloatArray:
        """Scores ``[s, s]``, ``(2N,)``; lower is better."""
        return self._twice(self.grasp_scores)

    @cached_property
    def source_row(self) -> np.ndarray:
        return self._twice(self.grasp_rows)

    @cached_property
    def flipped(self) -> np.ndarray:
        return read_only(np.arange(len(self)) >= self.n_grasps)

    @cached_property
    def tcp_points(self) -> FloatArray:
        return self._twice(self.grasp_tcp_points)

    @cached_property
    def widths(self) -> FloatArray:
        return self._twice(self.grasp_widths)

    @cached_property
    def depths(self) -> FloatArray:
        return self._twice(self.grasp_depths)

    def rotations_at(self, indices: ArrayLike) -> FloatArray:
        """``R_obj_ee`` ``(k, 3, 3)`` of the poses at ``indices``, without building all 2N."""
        idx = np.asarray(indices, dtype=np.int64)
        rotations = self.grasp_rotations[idx % max(self.n_grasps, 1)]
        flipped = (idx >= self.n_grasps)[:, None, None]
        return np.where(flipped, rotations * self.flip_diagonal, rotations)

    def T_obj_ee_at(self, indices: ArrayLike) -> FloatArray:
        """Transforms ``(k, 4, 4)`` of the poses at ``indices``."""
        idx = np.asarray(indices, dtype=np.int64)
        return make_T(self.rotations_at(idx), self.grasp_positions[self.grasp_index(idx)])

    @property
    def T_obj_ee(self) -> FloatArray:
        """All 2N poses as ``(2N, 4, 4)`` transforms (allocated on each access)."""
        return make_T(self.rotations, self.positions)

    @property
    def approach_axes(self) -> FloatArray:
        """Approach directions in the object frame, ``(2N, 3)`` (a flip keeps them)."""
        return self._twice(self.grasp_rotations[:, :, self.approach_index])

    def axis_component(self, axis: int, direction: ArrayLike) -> FloatArray:
        """``direction . (EE axis ``axis``)`` for all 2N poses, ``(2N,)``.

        With ``direction = R_base_obj[row]`` this is ``T_base_ee[:, row, axis]``, the quantity the
        direction filters test. It is computed on the N grasps and negated for the flipped half
        where the flip negates that axis, so it never builds the 2N rotations.
        """
        half = self.grasp_rotations[:, :, axis] @ np.asarray(direction, dtype=np.float64)
        flipped = half if self.flip_diagonal[axis] > 0 else -half
        return np.concatenate([half, flipped])


def _rotate_grasps(R_g: FloatArray, R_ee_graspnet: FloatArray) -> FloatArray:
    """``R_g @ R_ee_graspnet.T`` for (N, 3, 3) ``R_g``: EE column j is R_g (row j of R).

    Built column by column from the non-zero entries of ``R_ee_graspnet`` (one per row for the
    signed permutations robots use), which is exact and far faster than a batched 3x3 matmul.
    """
    out = np.empty_like(R_g)
    for j in range(3):
        terms = [k for k in range(3) if R_ee_graspnet[j, k] != 0.0]
        np.multiply(R_g[:, :, terms[0]], R_ee_graspnet[j, terms[0]], out=out[:, :, j])
        for k in terms[1:]:
            out[:, :, j] += R_g[:, :, k] * R_ee_graspnet[j, k]
    return out


def post_process(
    grasps: GraspSet,
    convention: GripperConvention,
    grasp_scale: float = 1.0,
    tcp_offset: float | None = None,
    constraints: Constraints | None = None,
) -> EEPoses:
    """End-effector poses of ``grasps`` for a robot convention: exactly reference section 3.

    1. ``R_obj_ee = R_g @ R_ee_graspnet.T``; 2. ``t_tcp = point * grasp_scale`` (depth unscaled);
    3. width clipped to the gripper range; 5. ``p = t_tcp + a * (depth - tcp_offset)`` with ``a``
    the approach column; 6. optional ``constraints = (axis, rmin, rmax)`` keep the rows whose
    ``t_tcp[axis]`` lies in ``[lo + rmin (hi - lo), lo + rmax (hi - lo)]`` over the scaled TCP
    range; 7. the copies turned 180 degrees about the approach axis follow, scores ``[s, s]``.
    (Step 4, the width-dependent depth correction, applies to none of the project robots.)
    """
    offset = convention.tcp_offset if tcp_offset is None else float(tcp_offset)
    rows = np.arange(len(grasps), dtype=np.int64)
    tcp = grasps.translations * grasp_scale
    R_g, depths, scores, widths = grasps.rotations, grasps.depths, grasps.scores, grasps.widths
    if constraints is not None:
        c_axis, rmin, rmax = constraints
        if c_axis not in AXES:
            raise ValueError(f"constraints axis must be x, y or z, got {c_axis!r}")
        values = tcp[:, AXES.index(c_axis)]
        lo, hi = values.min(), values.max()
        keep = (values >= lo + rmin * (hi - lo)) & (values <= lo + rmax * (hi - lo))
        rows, tcp, R_g = rows[keep], tcp[keep], R_g[keep]
        depths, scores, widths = depths[keep], scores[keep], widths[keep]

    rotations = _rotate_grasps(R_g, convention.R_ee_graspnet)
    approach = rotations[:, :, convention.approach_index]
    positions = approach * (depths - offset)[:, None]
    positions += tcp
    widths = np.clip(widths, convention.gripper_min_width, convention.gripper_max_width)
    return EEPoses(
        grasp_rotations=read_only(rotations),
        grasp_positions=read_only(positions),
        grasp_scores=read_only(scores),
        grasp_rows=read_only(rows),
        grasp_tcp_points=read_only(tcp),
        grasp_widths=read_only(widths),
        grasp_depths=read_only(depths),
        approach_index=convention.approach_index,
        flip_diagonal=FLIP_DIAGONALS[convention.ee_axis],
        tcp_offset=offset,
        grasp_scale=float(grasp_scale),
        source=grasps.path,
    )


def ee_poses_for_pick(grasps: GraspSet, convention: GripperConvention, pick: PickConfig) -> EEPoses:
    """:func:`post_process` with a pick block's ``grasp_scale``, ``tcp_offset``, ``constraints``."""
    return post_process(grasps, convention, pick.grasp_scale, pick.tcp_offset, pick.constraints)


def base_frame_poses(ee_poses: EEPoses, T_base_obj: ArrayLike) -> FloatArray:
    """``T_base_ee = T_base_obj @ T_obj_ee`` for all 2N poses, ``(2N, 4, 4)`` (section 4.1)."""
    return np.matmul(np.asarray(T_base_obj, dtype=np.float64), ee_poses.T_obj_ee)
