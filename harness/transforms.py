"""SE(3) and quaternion helpers, vectorised over leading dimensions.

Conventions (docs/architecture.md, Conventions): ``T_a_b`` is the 4x4 pose of frame b in frame a
(it maps b-coordinates into a); quaternions are **wxyz** everywhere in the harness, as in MuJoCo
and the reference. Rerun wants xyzw: convert only at that boundary with :func:`wxyz_to_xyzw`.

Every function accepts arrays with any number of leading (batch) dimensions, e.g. quaternions of
shape ``(..., 4)`` and rotations of shape ``(..., 3, 3)``, and never loops in Python over them.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


def _as_float(x: ArrayLike) -> FloatArray:
    return np.asarray(x, dtype=np.float64)


def quat_to_matrix(q_wxyz: ArrayLike) -> FloatArray:
    """Rotation matrices ``(..., 3, 3)`` of quaternions ``(..., 4)`` in wxyz order.

    The quaternions are normalised first, so a slightly denormalised input still gives a rotation.
    """
    q = _as_float(q_wxyz)
    if q.shape[-1:] != (4,):
        raise ValueError(f"quaternions must have shape (..., 4), got {q.shape}")
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = np.moveaxis(q, -1, 0)
    R = np.empty((*q.shape[:-1], 3, 3))
    R[..., 0, 0] = 1.0 - 2.0 * (y * y + z * z)
    R[..., 0, 1] = 2.0 * (x * y - w * z)
    R[..., 0, 2] = 2.0 * (x * z + w * y)
    R[..., 1, 0] = 2.0 * (x * y + w * z)
    R[..., 1, 1] = 1.0 - 2.0 * (x * x + z * z)
    R[..., 1, 2] = 2.0 * (y * z - w * x)
    R[..., 2, 0] = 2.0 * (x * z - w * y)
    R[..., 2, 1] = 2.0 * (y * z + w * x)
    R[..., 2, 2] = 1.0 - 2.0 * (x * x + y * y)
    return R


def matrix_to_quat(R: ArrayLike) -> FloatArray:
    """Unit wxyz quaternions ``(..., 4)`` of rotation matrices ``(..., 3, 3)``, with ``w >= 0``.

    Shepperd's method: per matrix, pick the largest of (trace, R00, R11, R22) to divide by, which
    keeps the result accurate for every rotation angle (a per-matrix choice, no Python loop).
    """
    R = _as_float(R)
    if R.shape[-2:] != (3, 3):
        raise ValueError(f"rotation matrices must have shape (..., 3, 3), got {R.shape}")
    m00, m11, m22 = R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]
    trace = m00 + m11 + m22
    # Four candidate quaternions (times 4 * their pivot component); pick the best conditioned.
    candidates = np.stack(
        [
            np.stack(
                [
                    1.0 + trace,
                    R[..., 2, 1] - R[..., 1, 2],
                    R[..., 0, 2] - R[..., 2, 0],
                    R[..., 1, 0] - R[..., 0, 1],
                ],
                axis=-1,
            ),
            np.stack(
                [
                    R[..., 2, 1] - R[..., 1, 2],
                    1.0 + m00 - m11 - m22,
                    R[..., 0, 1] + R[..., 1, 0],
                    R[..., 0, 2] + R[..., 2, 0],
                ],
                axis=-1,
            ),
            np.stack(
                [
                    R[..., 0, 2] - R[..., 2, 0],
                    R[..., 0, 1] + R[..., 1, 0],
                    1.0 - m00 + m11 - m22,
                    R[..., 1, 2] + R[..., 2, 1],
                ],
                axis=-1,
            ),
            np.stack(
                [
                    R[..., 1, 0] - R[..., 0, 1],
                    R[..., 0, 2] + R[..., 2, 0],
                    R[..., 1, 2] + R[..., 2, 1],
                    1.0 - m00 - m11 + m22,
                ],
                axis=-1,
            ),
        ],
        axis=-2,
    )  # (..., 4 candidates, 4 components)
    pivots = np.stack([trace, m00, m11, m22], axis=-1)
    best = np.argmax(pivots, axis=-1)[..., None, None]
    q = np.take_along_axis(candidates, best, axis=-2)[..., 0, :]
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return np.where(q[..., :1] < 0.0, -q, q)


Quat = tuple[float, float, float, float]


def rotation_quat(R: np.ndarray) -> Quat:
    """``matrix_to_quat`` of one rotation matrix (the top-left 3x3 of ``R``) as Python floats.

    The same operations in the same order as the vectorised function (so the same bits: each
    is one IEEE operation, and numpy sums a 4-vector left to right), without its ~40 us of
    numpy calls on tiny arrays: the executor tests poses with it every control step.
    """
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = R[:3, :3].tolist()
    trace = r00 + r11 + r22
    pivots = (trace, r00, r11, r22)
    best = 0  # the first largest pivot, as np.argmax picks it
    for index in (1, 2, 3):
        if pivots[index] > pivots[best]:
            best = index
    if best == 0:
        q = (1.0 + trace, r21 - r12, r02 - r20, r10 - r01)
    elif best == 1:
        q = (r21 - r12, 1.0 + r00 - r11 - r22, r01 + r10, r02 + r20)
    elif best == 2:
        q = (r02 - r20, r01 + r10, 1.0 - r00 + r11 - r22, r12 + r21)
    else:
        q = (r10 - r01, r02 + r20, r12 + r21, 1.0 - r00 - r11 + r22)
    w, x, y, z = _normalised(q)
    return (-w, -x, -y, -z) if w < 0.0 else (w, x, y, z)


def _normalised(q: Quat) -> Quat:
    """``q / np.linalg.norm(q)`` in Python floats (the squares summed left to right)."""
    w, x, y, z = q
    norm = math.sqrt(w * w + x * x + y * y + z * z)
    return (w / norm, x / norm, y / norm, z / norm)


def quat_angle(q1: Quat, q2: Quat) -> float:
    """``quat_angle_between`` of two wxyz quaternions given as Python floats (same bits)."""
    a, b = _normalised(q1), _normalised(q2)
    dot = abs(a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3])
    return 2.0 * float(np.arccos(min(dot, 1.0)))


def make_T(R: ArrayLike, p: ArrayLike) -> FloatArray:
    """Homogeneous transforms ``(..., 4, 4)`` from rotations ``(..., 3, 3)`` and positions.

    Positions have shape ``(..., 3)``; leading dimensions broadcast against each other.
    """
    R = _as_float(R)
    p = _as_float(p)
    batch = np.broadcast_shapes(R.shape[:-2], p.shape[:-1])
    T = np.zeros((*batch, 4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = p
    T[..., 3, 3] = 1.0
    return T


def invert_T(T: ArrayLike) -> FloatArray:
    """Inverse of rigid transforms ``(..., 4, 4)``: ``[R p; 0 1]^-1 = [R^T -R^T p; 0 1]``."""
    T = _as_float(T)
    R_t = np.swapaxes(T[..., :3, :3], -1, -2)
    p = T[..., :3, 3]
    return make_T(R_t, -np.einsum("...ij,...j->...i", R_t, p))


def pose_to_T(position: ArrayLike, quat_wxyz: ArrayLike) -> FloatArray:
    """Transforms ``(..., 4, 4)`` from positions ``(..., 3)`` and wxyz quaternions ``(..., 4)``."""
    return make_T(quat_to_matrix(quat_wxyz), position)


def T_to_pose(T: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Positions ``(..., 3)`` and wxyz quaternions ``(..., 4)`` of transforms ``(..., 4, 4)``."""
    T = _as_float(T)
    return T[..., :3, 3].copy(), matrix_to_quat(T[..., :3, :3])


def _axis_rotation(angle: FloatArray, axis: int) -> FloatArray:
    c, s = np.cos(angle), np.sin(angle)
    R = np.zeros((*angle.shape, 3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R[..., axis, axis] = 1.0
    R[..., i, i] = c
    R[..., j, j] = c
    R[..., i, j] = -s
    R[..., j, i] = s
    return R


def euler_xyz_deg_to_matrix(euler_deg: ArrayLike) -> FloatArray:
    """Rotation ``(..., 3, 3)`` of ``euler: [rx, ry, rz]`` (degrees), as in reference task YAMLs.

    Convention: **extrinsic XYZ** (rotate about the fixed x, then fixed y, then fixed z axis),
    i.e. ``R = Rz(rz) @ Ry(ry) @ Rx(rx)`` -- Isaac Sim's ``euler_angles_to_quat`` default
    (``extrinsic=True``), and scipy's ``Rotation.from_euler("xyz", ..., degrees=True)``.
    """
    euler = np.deg2rad(_as_float(euler_deg))
    if euler.shape[-1:] != (3,):
        raise ValueError(f"euler angles must have shape (..., 3), got {euler.shape}")
    Rx = _axis_rotation(euler[..., 0], 0)
    Ry = _axis_rotation(euler[..., 1], 1)
    Rz = _axis_rotation(euler[..., 2], 2)
    return Rz @ Ry @ Rx


def yaw_matrix(yaw: ArrayLike, degrees: bool = False) -> FloatArray:
    """Rotations ``(..., 3, 3)`` about +z by ``yaw`` (radians, or degrees with ``degrees=True``)."""
    angle = _as_float(yaw)
    if degrees:
        angle = np.deg2rad(angle)
    return _axis_rotation(angle, 2)


def quat_angle_between(q1_wxyz: ArrayLike, q2_wxyz: ArrayLike) -> FloatArray:
    """Rotation angle (radians, in [0, pi]) between wxyz quaternions, broadcast over ``(..., 4)``.

    ``2 * acos(min(|q1 . q2|, 1))`` on normalised quaternions: the reference's ``is_done``
    orientation error, insensitive to the q / -q sign ambiguity.
    """
    q1 = _as_float(q1_wxyz)
    q2 = _as_float(q2_wxyz)
    q1 = q1 / np.linalg.norm(q1, axis=-1, keepdims=True)
    q2 = q2 / np.linalg.norm(q2, axis=-1, keepdims=True)
    dot = np.abs(np.sum(q1 * q2, axis=-1))
    return 2.0 * np.arccos(np.minimum(dot, 1.0))


def quat_multiply(q1_wxyz: ArrayLike, q2_wxyz: ArrayLike) -> FloatArray:
    """Hamilton product ``q1 * q2`` (wxyz), the quaternion of ``R(q1) @ R(q2)``."""
    a = _as_float(q1_wxyz)
    b = _as_float(q2_wxyz)
    w1, x1, y1, z1 = np.moveaxis(a, -1, 0)
    w2, x2, y2, z2 = np.moveaxis(b, -1, 0)
    return np.stack(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ],
        axis=-1,
    )


def wxyz_to_xyzw(q_wxyz: ArrayLike) -> FloatArray:
    """Reorder quaternions from wxyz (harness, MuJoCo) to xyzw (Rerun, scipy)."""
    q = _as_float(q_wxyz)
    return np.concatenate([q[..., 1:], q[..., :1]], axis=-1)


def xyzw_to_wxyz(q_xyzw: ArrayLike) -> FloatArray:
    """Reorder quaternions from xyzw (Rerun, scipy) to wxyz (harness, MuJoCo)."""
    q = _as_float(q_xyzw)
    return np.concatenate([q[..., 3:], q[..., :3]], axis=-1)
