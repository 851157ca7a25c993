"""Grasp files (docs/reference-pick-skill.md section 2): a validated N x 17 GraspNet-style grasp
array.

:class:`GraspSet` / :func:`load_grasp_file` check the shape, dtype, finite values, score, width
and depth signs and the rotations, and name the offending cell in the ``InputFileError``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from harness.errors import InputFileError
from harness.grasps.arrays import FloatArray, read_only
from harness.reading import load_npy

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
            scores=read_only(data[:, 0].copy()),
            widths=read_only(data[:, 1].copy()),
            heights=read_only(data[:, 2].copy()),
            depths=read_only(data[:, 3].copy()),
            rotations=read_only(np.ascontiguousarray(rotations)),
            translations=read_only(data[:, 13:16].copy()),
            object_ids=read_only(data[:, 16].copy()),
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


# A grasp file holds ~10^3..10^5 rows; its header is checked against the file's size before
# numpy allocates what the header claims (a header of 10^12 rows asked for 124 TiB).
MAX_GRASP_BYTES = 1 << 30


def read_grasp_array(path: str | Path) -> np.ndarray:
    """The raw array of a grasp file, read by the read rule (``harness.reading.load_npy``:
    regular file, honest header, no pickles); ``InputFileError`` naming the file otherwise.
    No row validation."""
    path = Path(path)
    array = load_npy(path, MAX_GRASP_BYTES, what="grasp file")
    if not isinstance(array, np.ndarray):  # an .npz archive
        array.close()
        raise InputFileError(path, "is an .npz archive; expected one N x 17 .npy array")
    return array


def load_grasp_file(path: str | Path) -> GraspSet:
    """Load and validate an N x 17 ``.npy`` grasp file (see :meth:`GraspSet.from_array`)."""
    path = Path(path)
    if not path.is_file():
        raise InputFileError(path, "grasp file not found")
    return GraspSet.from_array(read_grasp_array(path), path)
