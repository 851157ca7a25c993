"""SE(3) / quaternion helpers: hand cases, scipy as an independent oracle, batching."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from harness import transforms as tf


def test_quat_to_matrix_hand_cases() -> None:
    np.testing.assert_allclose(tf.quat_to_matrix([1, 0, 0, 0]), np.eye(3))
    # 90 degrees about z (wxyz): x -> y, y -> -x.
    c = np.sqrt(0.5)
    R = tf.quat_to_matrix([c, 0, 0, c])
    np.testing.assert_allclose(R, [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-15)
    # Denormalised input is normalised first.
    np.testing.assert_allclose(tf.quat_to_matrix([2.0, 0, 0, 0]), np.eye(3))


def test_quat_to_matrix_matches_scipy_batched() -> None:
    rng = np.random.default_rng(0)
    q = rng.normal(size=(4, 5, 4))
    R = tf.quat_to_matrix(q)
    assert R.shape == (4, 5, 3, 3)
    expected = Rotation.from_quat(tf.wxyz_to_xyzw(q).reshape(-1, 4)).as_matrix()
    np.testing.assert_allclose(R.reshape(-1, 3, 3), expected, atol=1e-12)


def test_matrix_to_quat_round_trip_including_half_turns() -> None:
    rng = np.random.default_rng(1)
    q = rng.normal(size=(200, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    # Half turns (w = 0) about each axis and a diagonal: the ill-conditioned cases.
    q[:4] = [[0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1], [0, np.sqrt(0.5), np.sqrt(0.5), 0]]
    back = tf.matrix_to_quat(tf.quat_to_matrix(q))
    assert np.all(back[:, 0] >= 0.0)
    np.testing.assert_allclose(np.linalg.norm(back, axis=-1), 1.0)
    # Same rotation: q and back agree up to sign.
    sign = np.sign(np.sum(q * back, axis=-1))[:, None]
    np.testing.assert_allclose(back * sign, q, atol=1e-12)


def test_make_T_and_invert_T() -> None:
    rng = np.random.default_rng(2)
    R = Rotation.random(6, random_state=3).as_matrix().reshape(2, 3, 3, 3)
    p = rng.normal(size=(2, 3, 3))
    T = tf.make_T(R, p)
    assert T.shape == (2, 3, 4, 4)
    np.testing.assert_array_equal(T[..., 3, :], np.broadcast_to([0, 0, 0, 1.0], (2, 3, 4)))
    np.testing.assert_allclose(T @ tf.invert_T(T), np.broadcast_to(np.eye(4), T.shape), atol=1e-12)
    # Broadcasting one rotation against many positions.
    assert tf.make_T(np.eye(3), np.zeros((5, 3))).shape == (5, 4, 4)


def test_euler_xyz_is_extrinsic_xyz_degrees() -> None:
    # [90, 0, 90]: rotate about fixed x by 90 (y -> z), then about fixed z by 90 (x -> y).
    R = tf.euler_xyz_deg_to_matrix([90.0, 0.0, 90.0])
    np.testing.assert_allclose(R @ [1, 0, 0], [0, 1, 0], atol=1e-15)
    np.testing.assert_allclose(R @ [0, 1, 0], [0, 0, 1], atol=1e-15)
    # R = Rz @ Ry @ Rx, which is scipy's lowercase (extrinsic) "xyz".
    rng = np.random.default_rng(4)
    euler = rng.uniform(-180, 180, size=(10, 3))
    expected = Rotation.from_euler("xyz", euler, degrees=True).as_matrix()
    np.testing.assert_allclose(tf.euler_xyz_deg_to_matrix(euler), expected, atol=1e-12)
    # The reference robots' euler [0, 0, 90] is a yaw of 90 degrees.
    np.testing.assert_allclose(
        tf.euler_xyz_deg_to_matrix([0, 0, 90]), tf.yaw_matrix(np.pi / 2), atol=1e-15
    )


def test_yaw_matrix_radians_and_degrees() -> None:
    np.testing.assert_allclose(tf.yaw_matrix(90.0, degrees=True) @ [1, 0, 0], [0, 1, 0], atol=1e-15)
    yaws = np.array([0.1, -2.0, 3.0])
    np.testing.assert_allclose(
        tf.yaw_matrix(yaws), Rotation.from_euler("z", yaws[:, None]).as_matrix(), atol=1e-15
    )


def test_quat_angle_between() -> None:
    c = np.sqrt(0.5)
    assert tf.quat_angle_between([1, 0, 0, 0], [c, 0, 0, c]) == pytest.approx(np.pi / 2)
    # q and -q are the same rotation.
    assert tf.quat_angle_between([c, 0, 0, c], [-c, 0, 0, -c]) == pytest.approx(0.0, abs=1e-7)
    angles = tf.quat_angle_between(np.tile([1.0, 0, 0, 0], (3, 1)), [[0, 1, 0, 0]] * 3)
    np.testing.assert_allclose(angles, np.pi)


def test_quaternion_order_conversions_and_poses() -> None:
    q = np.array([0.9, 0.1, -0.2, 0.3])
    np.testing.assert_array_equal(tf.wxyz_to_xyzw(q), [0.1, -0.2, 0.3, 0.9])
    np.testing.assert_array_equal(tf.xyzw_to_wxyz(tf.wxyz_to_xyzw(q)), q)
    T = tf.pose_to_T([1.0, 2.0, 3.0], q)
    p, q_back = tf.T_to_pose(T)
    np.testing.assert_allclose(p, [1, 2, 3])
    np.testing.assert_allclose(q_back, q / np.linalg.norm(q), atol=1e-12)


def test_quat_multiply_composes_rotations() -> None:
    rng = np.random.default_rng(5)
    a, b = rng.normal(size=(2, 7, 4))
    a /= np.linalg.norm(a, axis=-1, keepdims=True)
    b /= np.linalg.norm(b, axis=-1, keepdims=True)
    np.testing.assert_allclose(
        tf.quat_to_matrix(tf.quat_multiply(a, b)),
        tf.quat_to_matrix(a) @ tf.quat_to_matrix(b),
        atol=1e-12,
    )


def test_rotation_quat_and_quat_angle_give_the_vectorised_results_bit_for_bit() -> None:
    """The executor's scalar pose tests (``rotation_quat``, ``quat_angle``) give exactly the
    floats of ``matrix_to_quat`` and ``quat_angle_between`` (the control schedules depend on
    them): random rotations, half turns, ties between pivots, rounded matrices."""
    rng = np.random.default_rng(4)
    q = rng.normal(size=(3000, 4))
    q[:4] = [[0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1], [0, np.sqrt(0.5), np.sqrt(0.5), 0]]
    q[4:8] = [[1, 0, 0, 0], [1, 1e-9, 0, 0], [np.sqrt(0.5), 0, np.sqrt(0.5), 0], [1, 1, 1, 1]]
    R = tf.quat_to_matrix(q)
    R[8:1000] = np.round(R[8:1000], 2)  # ties and near-ties between the diagonal pivots
    T = np.zeros((len(R), 4, 4))
    T[:, :3, :3] = R
    quats = tf.matrix_to_quat(R)
    scalar = np.array([tf.rotation_quat(t) for t in T])
    assert np.array_equal(scalar, quats)
    angles = tf.quat_angle_between(quats[:-1], quats[1:])
    pairs = zip(scalar[:-1].tolist(), scalar[1:].tolist(), strict=True)
    assert np.array_equal([tf.quat_angle(a, b) for a, b in pairs], angles)
