"""Grasp core: GraspNet-style annotations -> end-effector poses -> direction filters -> order.

Implements the reference Pick skill's pose post-processing and candidate selection
(docs/reference-pick-skill.md sections 2-4, 11, 12) as vectorised numpy, with no Python
loop over grasps:

- :class:`GraspSet` / :func:`load_grasp_file`: a validated N x 17 grasp file;
- :func:`post_process` -> :class:`EEPoses`: the 2N poses ``T_obj_ee`` for a robot's
  :class:`GripperConvention` (N grasps plus their 180-degree flips);
- :func:`filter_poses` / :func:`filter_ee_poses` -> :class:`FilterResult`: the direction filters
  and ``direction_to_obj`` in the arm base frame, every mask kept;
- :func:`resolve_filters` / :func:`neutral_form`: robot-neutral ``approach_filter`` /
  ``facing_filter`` <-> per-axis ``filter_{x,y,z}_dir``;
- :func:`reference_order` / :func:`strict_order` -> :class:`CandidateOrder`;
- :func:`select_candidates` -> :class:`CandidateSelection`: all of it for one pick.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from harness.config import AxisFilter, ConfigError, PickConfig, reversed_band_message
from harness.errors import InputFileError
from harness.transforms import make_T

FloatArray = NDArray[np.float64]

AXES = ("x", "y", "z")


def _read_only(array: np.ndarray) -> np.ndarray:
    """Mark an array read-only: grasp sets and poses are shared, never edited in place."""
    array.flags.writeable = False
    return array


@dataclass(frozen=True)
class GripperConvention:
    """How a robot's end-effector frame relates to GraspNet grasp axes.

    ``R_ee_graspnet`` maps grasp axes to EE axes (``R_obj_ee = R_g @ R_ee_graspnet.T``);
    ``ee_axis`` is the EE axis the reference treats as the approach (``approach_axis`` is the
    same letter, named for the robot-neutral filters); ``facing_axis`` is the EE axis equal to
    -g_z, the one the canonical "forward 90" filters constrain.
    """

    R_ee_graspnet: np.ndarray
    ee_axis: str
    facing_axis: str
    tcp_offset: float
    gripper_min_width: float
    gripper_max_width: float

    def __post_init__(self) -> None:
        R = np.asarray(self.R_ee_graspnet, dtype=float)
        if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-9):
            raise ValueError("R_ee_graspnet must be a 3x3 rotation")
        if self.ee_axis not in AXES or self.facing_axis not in AXES:
            raise ValueError("ee_axis and facing_axis must be x, y or z")
        if self.ee_axis == self.facing_axis:
            raise ValueError("ee_axis and facing_axis must differ")
        object.__setattr__(self, "R_ee_graspnet", R)

    @property
    def approach_axis(self) -> str:
        return self.ee_axis

    @property
    def approach_index(self) -> int:
        return AXES.index(self.ee_axis)


# Reference values (docs/reference-pick-skill.md section 3) for the three project robots.
# robots/<name>/robot.yaml
# is the source of truth at run time; these serve tests and tools that run without a robot model.
REFERENCE_CONVENTIONS: dict[str, GripperConvention] = {
    "fr3": GripperConvention(
        R_ee_graspnet=np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]),
        ee_axis="z",
        facing_axis="x",
        tcp_offset=0.1043,
        gripper_min_width=0.0,
        gripper_max_width=0.08,
    ),
    "lift2": GripperConvention(
        R_ee_graspnet=np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]),
        ee_axis="x",
        facing_axis="z",
        tcp_offset=0.125,
        gripper_min_width=0.0,
        gripper_max_width=0.088,
    ),
    "split_aloha": GripperConvention(
        R_ee_graspnet=np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]),
        ee_axis="z",
        facing_axis="y",
        tcp_offset=0.12,
        gripper_min_width=0.0,
        gripper_max_width=0.10,
    ),
}


# --------------------------------------------------------------------------------------------
# Grasp files (docs/reference-pick-skill.md section 2)

GRASP_COLUMNS = 17
ROTATION_TOLERANCE = 1e-3
COLUMN_NAMES: tuple[str, ...] = (
    "score",
    "width",
    "height",
    "depth",
    *(f"rotation[{i}][{j}]" for i in range(3) for j in range(3)),
    "translation x",
    "translation y",
    "translation z",
    "object id",
)
LAYOUT = "score, width, height, depth, 3x3 rotation row-major, translation xyz, object id"


def _cell(row: int, column: int) -> str:
    return f"row {row} column {column} ({COLUMN_NAMES[column]})"


@dataclass(frozen=True, eq=False)
class GraspSet:
    """N GraspNet-style grasps in the object frame, one per row of an N x 17 grasp file.

    Columns (``Aligned_grasp_sparse.npy`` layout): score (force-closure friction coefficient,
    lower is better), width, height, depth (m), rotation ``R_g`` (row-major; g_x approaches,
    g_y closes), translation (the grasp point, m), object id. Values are held as float64.
    """

    path: str
    scores: FloatArray
    widths: FloatArray
    heights: FloatArray
    depths: FloatArray
    rotations: FloatArray
    translations: FloatArray
    object_ids: FloatArray

    def __len__(self) -> int:
        return int(self.scores.shape[0])

    @classmethod
    def from_array(cls, array: object, path: str | Path = "<array>") -> GraspSet:
        """Validate an N x 17 array and split it into columns; ``InputFileError`` names the cell.

        Checks, in order: shape N x 17 with N >= 1, a floating-point dtype, finite values,
        scores > 0, widths >= 0, depths >= 0, rotations orthonormal within 1e-3 with det > 0.
        Rows and columns in messages are 0-based, as in numpy.
        """
        path = str(path)
        if not isinstance(array, np.ndarray):
            raise InputFileError(path, f"expected a numpy array, got {type(array).__name__}")
        if array.ndim != 2 or array.shape[1] != GRASP_COLUMNS:
            raise InputFileError(
                path, f"expected an N x 17 grasp array ({LAYOUT}), got shape {array.shape}", "shape"
            )
        if array.shape[0] == 0:
            raise InputFileError(path, "holds no grasps (shape (0, 17))", "shape")
        if not np.issubdtype(array.dtype, np.floating):
            raise InputFileError(
                path, f"expected floating-point values, got dtype {array.dtype}", "dtype"
            )
        data = array.astype(np.float64)
        _check_cells(path, data, ~np.isfinite(data), "is not finite")
        _check_cells(path, data[:, :1], data[:, :1] <= 0.0, "must be > 0 (lower is better)")
        _check_cells(path, data[:, :2], data[:, :2] < 0.0, "must be >= 0", first_column=1)
        _check_cells(path, data[:, :4], data[:, :4] < 0.0, "must be >= 0", first_column=3)
        rotations = data[:, 4:13].reshape(-1, 3, 3)
        _check_rotations(path, rotations)
        return cls(
            path=path,
            scores=_read_only(data[:, 0].copy()),
            widths=_read_only(data[:, 1].copy()),
            heights=_read_only(data[:, 2].copy()),
            depths=_read_only(data[:, 3].copy()),
            rotations=_read_only(np.ascontiguousarray(rotations)),
            translations=_read_only(data[:, 13:16].copy()),
            object_ids=_read_only(data[:, 16].copy()),
        )


def _check_cells(
    path: str, data: FloatArray, bad: np.ndarray, message: str, first_column: int = 0
) -> None:
    """Raise for the first (row-major) True cell of ``bad`` at or after ``first_column``."""
    bad = bad[:, first_column:]
    if not bad.any():
        return
    row, column = np.unravel_index(int(np.argmax(bad)), bad.shape)
    column += first_column
    value = float(data[row, column])
    raise InputFileError(path, f"value {value!r} {message}", _cell(int(row), int(column)))


def _check_rotations(path: str, rotations: FloatArray) -> None:
    gram_error = np.abs(rotations @ np.swapaxes(rotations, 1, 2) - np.eye(3)).max(axis=(1, 2))
    bad = gram_error > ROTATION_TOLERANCE
    if bad.any():
        row = int(np.argmax(bad))
        raise InputFileError(
            path,
            f"rotation is not orthonormal: max |R R^T - I| = {gram_error[row]:.3g} "
            f"> {ROTATION_TOLERANCE:g}",
            f"row {row} columns 4-12 (rotation)",
        )
    det = np.linalg.det(rotations)
    bad = det <= 0.0
    if bad.any():
        row = int(np.argmax(bad))
        raise InputFileError(
            path,
            f"rotation has determinant {det[row]:.3g} (a reflection); a proper rotation has +1",
            f"row {row} columns 4-12 (rotation)",
        )


def load_grasp_file(path: str | Path) -> GraspSet:
    """Load and validate an N x 17 ``.npy`` grasp file (see :meth:`GraspSet.from_array`)."""
    path = Path(path)
    if not path.is_file():
        raise InputFileError(path, "grasp file not found")
    try:
        array = np.load(path, allow_pickle=False)
    except (OSError, ValueError, EOFError) as exc:
        raise InputFileError(path, f"cannot read as a .npy array: {exc}") from None
    if not isinstance(array, np.ndarray):  # an .npz archive
        array.close()
        raise InputFileError(path, "is an .npz archive; expected one N x 17 .npy array")
    return GraspSet.from_array(array, path)


# --------------------------------------------------------------------------------------------
# End-effector poses (docs/reference-pick-skill.md section 3)

# Right-multiplied onto R_obj_ee: a 180-degree turn about the approach axis (step 7).
FLIP_DIAGONALS: dict[str, FloatArray] = {
    "x": _read_only(np.array([1.0, -1.0, -1.0])),
    "y": _read_only(np.array([-1.0, 1.0, -1.0])),
    "z": _read_only(np.array([-1.0, -1.0, 1.0])),
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
        return _read_only(np.concatenate([values, values]))

    @cached_property
    def rotations(self) -> FloatArray:
        """``R_obj_ee`` of all 2N poses, ``(2N, 3, 3)``."""
        flipped = self.grasp_rotations * self.flip_diagonal
        return _read_only(np.concatenate([self.grasp_rotations, flipped]))

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
        return _read_only(np.arange(len(self)) >= self.n_grasps)

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
    """End-effector poses of ``grasps`` for a robot convention: exactly
    docs/reference-pick-skill.md section 3.

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
        grasp_rotations=_read_only(rotations),
        grasp_positions=_read_only(positions),
        grasp_scores=_read_only(scores),
        grasp_rows=_read_only(rows),
        grasp_tcp_points=_read_only(tcp),
        grasp_widths=_read_only(widths),
        grasp_depths=_read_only(depths),
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
    """``T_base_ee = T_base_obj @ T_obj_ee`` for all 2N poses, ``(2N, 4, 4)``
    (docs/reference-pick-skill.md section 4.1)."""
    return np.matmul(np.asarray(T_base_obj, dtype=np.float64), ee_poses.T_obj_ee)


# --------------------------------------------------------------------------------------------
# Direction filters in the arm base frame (docs/reference-pick-skill.md sections 4.2, 4.3)

FILTER_KEYS: dict[str, str] = {axis: f"filter_{axis}_dir" for axis in AXES}
# direction -> (row of T_base_ee: base +X or +Z, sign)
DIRECTION_ROW_SIGN: dict[str, tuple[int, int]] = {
    "forward": (0, 1),
    "backward": (0, -1),
    "upward": (2, 1),
    "downward": (2, -1),
}


def axis_filter_mask(component: ArrayLike, spec: AxisFilter) -> np.ndarray:
    """Keep-mask of one direction filter given ``e = T_base_ee[:, row, column]``.

    ``[dir, a]`` keeps ``e >= cos a`` (forward/upward) or ``e <= cos a`` (backward/downward);
    ``[dir, a1, a2]`` keeps ``cos a1 <= e <= cos a2`` or ``cos a2 <= e <= cos a1``. The angles are
    measured from base +X or +Z, and cos(90 deg) is 6.1e-17, so ``forward 90`` rejects an axis
    that is exactly perpendicular -- both as in the reference.
    """
    e = np.asarray(component)
    _, sign = DIRECTION_ROW_SIGN[spec.direction]
    if not spec.is_band:
        limit = np.cos(np.deg2rad(spec.angles[0]))
        return e >= limit if sign > 0 else e <= limit
    cos1, cos2 = np.cos(np.deg2rad(spec.angles[0])), np.cos(np.deg2rad(spec.angles[1]))
    if sign > 0:
        return (e >= cos1) & (e <= cos2)
    return (e <= cos1) & (e >= cos2)


@dataclass(frozen=True, eq=False)
class FilterResult:
    """Every active filter's keep-mask over the 2N poses, and their AND.

    ``masks`` is keyed by the reference config key (``filter_x_dir``, ``filter_z_dir``,
    ``direction_to_obj``) so reports can say which filter rejected what. With no active filter
    every pose passes, as in the reference.
    """

    masks: dict[str, np.ndarray]
    combined: np.ndarray

    @property
    def total(self) -> int:
        return int(self.combined.shape[0])

    @property
    def passed(self) -> int:
        return int(np.count_nonzero(self.combined))

    @property
    def passing_indices(self) -> np.ndarray:
        return np.flatnonzero(self.combined)

    def counts(self) -> dict[str, int]:
        """Pass count per filter key."""
        return {key: int(np.count_nonzero(mask)) for key, mask in self.masks.items()}


def _combine(masks: dict[str, np.ndarray], total: int) -> FilterResult:
    if not masks:
        return FilterResult(masks={}, combined=np.ones(total, dtype=bool))
    combined = np.logical_and.reduce(list(masks.values()))
    return FilterResult(masks=masks, combined=combined)


def _direction_to_obj_mask(ee_y: np.ndarray, obj_y: float, side: str) -> np.ndarray:
    if side == "right":
        return ee_y <= obj_y
    if side == "left":
        return ee_y > obj_y
    raise ValueError(f"direction_to_obj must be 'left' or 'right', got {side!r}")


def filter_poses(
    T_base_ee: ArrayLike,
    filters: Mapping[str, AxisFilter],
    direction_to_obj: str | None = None,
    T_base_obj: ArrayLike | None = None,
) -> FilterResult:
    """Direction filters on base-frame poses ``T_base_ee`` ``(M, 4, 4)``
    (docs/reference-pick-skill.md sections 4.2-4.4).

    ``filters`` maps ``filter_{x,y,z}_dir`` (or the bare letter) to an :class:`AxisFilter`; the
    letter selects the EE axis (column of the rotation); masks are keyed ``filter_{x,y,z}_dir``.
    ``direction_to_obj`` ("left" / "right") compares the EE origin's base y with the object's,
    ``T_base_obj[1, 3]``.
    """
    T = np.asarray(T_base_ee, dtype=np.float64)
    masks: dict[str, np.ndarray] = {}
    for key, spec in filters.items():
        column = _filter_column(key)
        row, _ = DIRECTION_ROW_SIGN[spec.direction]
        masks[FILTER_KEYS[AXES[column]]] = axis_filter_mask(T[:, row, column], spec)
    if direction_to_obj is not None:
        if T_base_obj is None:
            raise ValueError("direction_to_obj needs T_base_obj")
        obj_y = float(np.asarray(T_base_obj, dtype=np.float64)[1, 3])
        masks["direction_to_obj"] = _direction_to_obj_mask(T[:, 1, 3], obj_y, direction_to_obj)
    return _combine(masks, T.shape[0])


def filter_ee_poses(
    ee_poses: EEPoses,
    T_base_obj: ArrayLike,
    filters: Mapping[str, AxisFilter],
    direction_to_obj: str | None = None,
) -> FilterResult:
    """:func:`filter_poses` of ``T_base_obj @ T_obj_ee``, computing only the entries it needs.

    Each filter reads one entry of ``T_base_ee`` per pose, ``R_base_obj[row] . R_obj_ee[:, col]``;
    computing just those (instead of 2N full 4x4 products) is what makes a million poses cheap.
    """
    T_bo = np.asarray(T_base_obj, dtype=np.float64)
    masks: dict[str, np.ndarray] = {}
    for key, spec in filters.items():
        row, _ = DIRECTION_ROW_SIGN[spec.direction]
        column = _filter_column(key)
        component = ee_poses.axis_component(column, T_bo[row, :3])
        masks[FILTER_KEYS[AXES[column]]] = axis_filter_mask(component, spec)
    if direction_to_obj is not None:
        ee_y = ee_poses.grasp_positions @ T_bo[1, :3] + T_bo[1, 3]
        side = _direction_to_obj_mask(ee_y, float(T_bo[1, 3]), direction_to_obj)
        masks["direction_to_obj"] = np.concatenate([side, side])
    return _combine(masks, len(ee_poses))


def _filter_column(key: str) -> int:
    """EE axis (rotation column) of a filter key: ``filter_y_dir`` (or just ``y``) -> 1."""
    for axis, name in FILTER_KEYS.items():
        if key in (name, axis):
            return AXES.index(axis)
    raise ValueError(f"unknown filter key {key!r}; expected one of {list(FILTER_KEYS.values())}")


# --------------------------------------------------------------------------------------------
# Robot-neutral filters

NEUTRAL_KEYS = ("approach_filter", "facing_filter")


def _neutral_axis(key: str, convention: GripperConvention) -> str:
    return convention.approach_axis if key == "approach_filter" else convention.facing_axis


def resolve_filter_sources(pick: PickConfig, convention: GripperConvention) -> dict[str, str]:
    """For each active ``filter_*_dir`` of :func:`resolve_filters`, the pick key that set it."""
    sources = {key: key for key in pick.axis_filters()}
    for neutral in NEUTRAL_KEYS:
        if getattr(pick, neutral) is not None:
            sources[FILTER_KEYS[_neutral_axis(neutral, convention)]] = neutral
    return dict(sorted(sources.items()))


def resolve_filters(pick: PickConfig, convention: GripperConvention) -> dict[str, AxisFilter]:
    """The per-axis filters for this robot: explicit ``filter_*_dir`` plus the neutral ones.

    ``approach_filter`` becomes ``filter_{approach_axis}_dir`` and ``facing_filter`` becomes
    ``filter_{facing_axis}_dir``. Setting the same EE axis twice is a ``ConfigError``.
    """
    resolved: dict[str, AxisFilter] = dict(pick.axis_filters())
    for neutral in NEUTRAL_KEYS:
        spec: AxisFilter | None = getattr(pick, neutral)
        if spec is None:
            continue
        axis = _neutral_axis(neutral, convention)
        key = FILTER_KEYS[axis]
        if key in resolved:
            role = "approach" if neutral == "approach_filter" else "facing"
            raise ConfigError(
                f"{neutral} {spec.as_list()} filters this robot's {role} axis, EE {axis}, "
                f"which {key} {resolved[key].as_list()} already filters; set only one of them",
                key=neutral,
            )
        resolved[key] = spec
    return dict(sorted(resolved.items()))


def neutral_form(
    filters: Mapping[str, AxisFilter], convention: GripperConvention
) -> dict[str, AxisFilter]:
    """The inverse of :func:`resolve_filters`: per-axis filters as approach / facing filters.

    The filter on the approach axis becomes ``approach_filter``, the one on the facing axis
    ``facing_filter``; a filter on the third axis has no neutral name and keeps its key.
    """
    names = {
        FILTER_KEYS[convention.approach_axis]: "approach_filter",
        FILTER_KEYS[convention.facing_axis]: "facing_filter",
    }
    for key in filters:
        _filter_column(key)
    return {names.get(key, key): spec for key, spec in filters.items()}


def check_strict_filters(filters: Mapping[str, AxisFilter]) -> None:
    """Strict semantics: a 3-element filter whose angle order can never pass is a ConfigError."""
    for key, spec in filters.items():
        if spec.never_passes():
            raise ConfigError(reversed_band_message(key, spec), key=key)


# --------------------------------------------------------------------------------------------
# Candidate order (docs/reference-pick-skill.md sections 4.4, 4.5)

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
    drawn = rng.choice(top, size=max_candidates, replace=True, p=_weights(scores[top]))
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
        drawn = rng.choice(passing, size=count, replace=False, p=_weights(scores[passing]))
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


# --------------------------------------------------------------------------------------------
# One entry point for the episode code


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


def select_candidates(
    ee_poses: EEPoses,
    convention: GripperConvention,
    pick: PickConfig,
    T_base_obj: ArrayLike,
    rng: np.random.Generator,
    *,
    max_candidates: int = CANDIDATE_BATCH,
    strict_sampling: bool | None = None,
) -> CandidateSelection:
    """Resolve the pick's filters for this robot, apply them in the arm base frame, order.

    ``T_base_obj`` is the object pose in the arm base frame at selection time. Randomness comes
    only from ``rng``. Under strict semantics a filter that can never pass is a ConfigError.
    """
    T_bo = np.asarray(T_base_obj, dtype=np.float64)
    if T_bo.shape != (4, 4):
        raise ValueError(f"T_base_obj must be a 4x4 transform, got shape {T_bo.shape}")
    filters = resolve_filters(pick, convention)
    if pick.semantics == "strict":
        check_strict_filters(filters)
    result = filter_ee_poses(ee_poses, T_bo, filters, pick.direction_to_obj)
    if strict_sampling is None:
        strict_sampling = pick.strict_sampling
    order = order_candidates(
        ee_poses.scores, result.combined, pick.semantics, rng, max_candidates, strict_sampling
    )
    return CandidateSelection(
        ee_poses=ee_poses,
        T_base_obj=T_bo,
        filters=filters,
        filter_sources=resolve_filter_sources(pick, convention),
        filter_result=result,
        order=order,
    )
