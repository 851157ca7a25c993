"""TOPP-RA and Ruckig timing: limits, endpoints, rest, path fidelity, speed scale, failures."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.interpolate import CubicSpline
from scipy.spatial import cKDTree

from harness.planning.timing import (
    TimingError,
    TimingLimits,
    Trajectory,
    gripper_trajectory,
    plan_timing,
    ruckig_through,
    time_parameterize_ruckig,
    time_parameterize_toppra,
)

# FR3-like limits.
VEL = np.array([2.62, 2.62, 2.62, 2.62, 5.26, 4.18, 5.26])
ACC = np.full(7, 10.0)
JERK = np.full(7, 5000.0)
HOME = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])

# A realistic pick path: home -> over the object -> pre-grasp -> grasp (joint space).
PICK_WAYPOINTS = np.array(
    [
        HOME,
        [0.25, -0.45, 0.05, -2.20, 0.02, 1.75, 0.95],
        [0.40, -0.10, 0.08, -2.05, 0.03, 1.95, 1.10],
        [0.42, 0.05, 0.08, -1.95, 0.03, 2.00, 1.12],
        [0.43, 0.12, 0.08, -1.90, 0.03, 2.02, 1.13],
    ]
)


def dense(trajectory: Trajectory, count: int = 20001):
    ts = np.linspace(0.0, trajectory.duration, count)
    return (ts, *trajectory.sample_many(ts))


def chord_spline(waypoints: np.ndarray) -> CubicSpline:
    """The documented path: not-a-knot cubic over the normalised cumulative chord length."""
    chord = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(waypoints, axis=0), axis=1))])
    return CubicSpline(chord / chord[-1], waypoints, bc_type="not-a-knot")


def distance_to_segment(q: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    direction = b - a
    lam = np.clip((q - a) @ direction / (direction @ direction), 0.0, 1.0)
    return np.linalg.norm(q - (a + lam[:, None] * direction), axis=1)


# --------------------------------------------------------------------------------------------
# TOPP-RA


@pytest.mark.parametrize("count", [2, 3, 5, 12])
def test_toppra_respects_limits_and_rests_at_exact_endpoints(count: int) -> None:
    rng = np.random.default_rng(count)
    waypoints = HOME + np.cumsum(rng.normal(0.0, 0.3, (count, 7)), axis=0)
    trajectory = time_parameterize_toppra(waypoints, VEL, ACC)
    _ts, q, qd, qdd = dense(trajectory)
    assert trajectory.method == "toppra"
    assert np.max(np.abs(qd) / VEL) <= 1.0 + 1e-3
    assert np.max(np.abs(qdd) / ACC) <= 1.02
    # The limits are actually used: some joint gets close to its velocity or acceleration limit.
    assert max(np.max(np.abs(qd) / VEL), np.max(np.abs(qdd) / ACC)) > 0.9
    np.testing.assert_array_equal(q[0], waypoints[0])
    np.testing.assert_array_equal(q[-1], waypoints[-1])
    for state in (qd[0], qd[-1], qdd[0], qdd[-1]):
        np.testing.assert_array_equal(state, 0.0)
    # Sampling outside [0, duration] clips: before the start and after the end the arm rests.
    np.testing.assert_array_equal(trajectory.sample(-1.0)[0], waypoints[0])
    np.testing.assert_array_equal(trajectory.sample(trajectory.duration + 5.0)[0], waypoints[-1])
    np.testing.assert_array_equal(trajectory.sample(trajectory.duration + 5.0)[1], 0.0)


def test_toppra_follows_the_waypoint_spline_through_every_waypoint() -> None:
    trajectory = time_parameterize_toppra(PICK_WAYPOINTS, VEL, ACC)
    _, q, qd, _ = dense(trajectory)
    spline_points = chord_spline(PICK_WAYPOINTS)(np.linspace(0.0, 1.0, 200001))
    spacing = np.max(np.linalg.norm(np.diff(spline_points, axis=0), axis=1))
    off_path, _ = cKDTree(spline_points).query(q)
    assert off_path.max() <= spacing
    # Passes through every waypoint (within one sample's travel).
    step = np.max(np.linalg.norm(qd, axis=1)) * trajectory.duration / (len(q) - 1)
    near, _ = cKDTree(q).query(PICK_WAYPOINTS)
    assert near.max() <= step
    # Progresses forward along the path: the nearest spline index never decreases.
    _, index = cKDTree(spline_points).query(q)
    assert np.all(np.diff(index) >= -1)


def test_toppra_two_waypoints_and_collinear_waypoints_stay_on_the_straight_line() -> None:
    goal = HOME + np.array([0.6, 0.4, -0.3, 0.5, 1.0, -0.2, 0.7])
    for waypoints in (
        np.array([HOME, goal]),
        np.array([HOME, HOME + 0.1 * (goal - HOME), HOME + 0.7 * (goal - HOME), goal]),
    ):
        trajectory = time_parameterize_toppra(waypoints, VEL, ACC)
        _, q, _, _ = dense(trajectory)
        assert distance_to_segment(q, HOME, goal).max() < 1e-12
        progress = (q - HOME) @ (goal - HOME) / ((goal - HOME) @ (goal - HOME))
        assert progress.min() >= 0.0 and progress.max() <= 1.0
        assert np.all(np.diff(progress) >= -1e-12)


def test_toppra_two_point_move_is_bang_bang_time_optimal() -> None:
    # One joint moving 1 rad with v = 2.62, a = 10: the time-optimal profile accelerates at the
    # limit to the peak speed sqrt(a * d) = 3.16 > v, so it cruises: T = d / v + v / a.
    goal = HOME.copy()
    goal[0] += 1.0
    trajectory = time_parameterize_toppra([HOME, goal], VEL, ACC)
    assert trajectory.duration == pytest.approx(1.0 / 2.62 + 2.62 / 10.0, rel=5e-3)


def test_toppra_speed_scale_halves_velocity_and_doubles_duration() -> None:
    full = time_parameterize_toppra(PICK_WAYPOINTS, VEL, ACC)
    half = time_parameterize_toppra(PICK_WAYPOINTS, VEL, ACC, speed_scale=0.5)
    assert half.duration == pytest.approx(2.0 * full.duration, rel=1e-2)
    _, _, qd_full, _ = dense(full)
    _, q_half, qd_half, qdd_half = dense(half)
    assert np.max(np.abs(qd_half) / (0.5 * VEL)) <= 1.0 + 1e-3
    assert np.max(np.abs(qdd_half) / (0.25 * ACC)) <= 1.02
    assert np.max(np.abs(qd_half)) == pytest.approx(0.5 * np.max(np.abs(qd_full)), rel=1e-2)
    np.testing.assert_array_equal(q_half[-1], PICK_WAYPOINTS[-1])


def test_toppra_duplicate_waypoints_are_dropped() -> None:
    goal = PICK_WAYPOINTS[-1]
    with_duplicates = np.array([HOME, HOME, goal, goal, goal])
    a = time_parameterize_toppra(with_duplicates, VEL, ACC)
    b = time_parameterize_toppra([HOME, goal], VEL, ACC)
    assert a.duration == pytest.approx(b.duration, rel=1e-9)
    still = time_parameterize_toppra([HOME, HOME, HOME], VEL, ACC)
    assert still.duration == 0.0
    q, qd, _ = still.sample(0.3)
    np.testing.assert_array_equal(q, HOME)
    np.testing.assert_array_equal(qd, 0.0)


def test_toppra_failure_raises_timing_error_with_return_code() -> None:
    # Two grid points leave both ends of the only interval at rest: no motion is possible.
    with pytest.raises(TimingError, match="at rest"):
        time_parameterize_toppra(PICK_WAYPOINTS, VEL, ACC, gridpoints=2)
    # An acceleration limit that underflows in the solver: toppra returns None.
    with pytest.raises(TimingError, match="code") as info:
        time_parameterize_toppra(PICK_WAYPOINTS, VEL, np.full(7, 1e-300))
    assert info.value.return_code is not None


def test_toppra_rejects_malformed_input() -> None:
    with pytest.raises(ValueError, match="shape"):
        time_parameterize_toppra(np.zeros(7), VEL, ACC)
    with pytest.raises(ValueError, match="NaN"):
        time_parameterize_toppra([HOME, np.full(7, np.nan)], VEL, ACC)
    with pytest.raises(ValueError, match="positive"):
        time_parameterize_toppra(PICK_WAYPOINTS, -VEL, ACC)
    with pytest.raises(ValueError, match="DoF"):
        time_parameterize_toppra(PICK_WAYPOINTS, VEL[:6], ACC[:6])
    with pytest.raises(ValueError, match="speed_scale"):
        time_parameterize_toppra(PICK_WAYPOINTS, VEL, ACC, speed_scale=1.5)


def test_toppra_extreme_path_terminates() -> None:
    # A path with absurd curvature must not grow the grid without bound (toppra's own proposal
    # doubles it until memory runs out).
    trajectory = time_parameterize_toppra([[0.0, 0.0], [1e12, 1.0], [2.0, 0.0]], [1, 1], [1, 1])
    assert np.isfinite(trajectory.duration)
    assert len(trajectory.segments[0].profile.ss) <= 1000


# --------------------------------------------------------------------------------------------
# Ruckig


def test_ruckig_phase_sync_is_a_straight_jerk_limited_rest_to_rest_move() -> None:
    goal = PICK_WAYPOINTS[-1]
    trajectory = time_parameterize_ruckig(HOME, goal, VEL, ACC, JERK)
    ts, q, qd, qdd = dense(trajectory)
    assert trajectory.method == "ruckig"
    np.testing.assert_array_equal(q[0], HOME)
    np.testing.assert_array_equal(q[-1], goal)
    for state in (qd[0], qd[-1], qdd[0], qdd[-1]):
        np.testing.assert_allclose(state, 0.0, atol=1e-12)
    assert distance_to_segment(q, HOME, goal).max() < 1e-9
    assert np.max(np.abs(qd) / VEL) <= 1.0 + 1e-6
    assert np.max(np.abs(qdd) / ACC) <= 1.0 + 1e-6
    jerk = np.diff(qdd, axis=0) / np.diff(ts)[:, None]
    assert np.max(np.abs(jerk) / JERK) <= 1.0 + 1e-3
    # Some joint reaches its velocity or acceleration limit (time optimal).
    assert max(np.max(np.abs(qd) / VEL), np.max(np.abs(qdd) / ACC)) > 0.999


def test_ruckig_speed_scale_halves_velocity_and_doubles_duration() -> None:
    goal = PICK_WAYPOINTS[-1]
    full = time_parameterize_ruckig(HOME, goal, VEL, ACC, JERK)
    half = time_parameterize_ruckig(HOME, goal, VEL, ACC, JERK, speed_scale=0.5)
    assert half.duration == pytest.approx(2.0 * full.duration, rel=1e-6)
    _, _, qd_full, _ = dense(full)
    _, _, qd_half, _ = dense(half)
    assert np.max(np.abs(qd_half)) == pytest.approx(0.5 * np.max(np.abs(qd_full)), rel=1e-3)


def test_ruckig_through_stops_at_every_waypoint() -> None:
    trajectory = ruckig_through(PICK_WAYPOINTS, VEL, ACC, JERK)
    assert len(trajectory.segments) == len(PICK_WAYPOINTS) - 1
    for segment, (a, b) in zip(
        trajectory.segments, itertools.pairwise(PICK_WAYPOINTS), strict=True
    ):
        q, qd, _ = trajectory.sample(segment.end_time)
        np.testing.assert_allclose(q, b, atol=1e-12)
        np.testing.assert_allclose(qd, 0.0, atol=1e-12)
        inside = np.linspace(segment.start_time, segment.end_time, 501)
        assert distance_to_segment(trajectory.sample_many(inside)[0], a, b).max() < 1e-9
    # It stops at corners, so it is slower than TOPP-RA on the same path.
    assert trajectory.duration > time_parameterize_toppra(PICK_WAYPOINTS, VEL, ACC).duration


def test_ruckig_invalid_input_raises_timing_error() -> None:
    with pytest.raises(ValueError, match="same length"):
        time_parameterize_ruckig(HOME, HOME[:6], VEL, ACC, JERK)
    # A move Ruckig refuses (its duration exceeds Ruckig's maximum trajectory duration).
    with pytest.raises(TimingError):
        time_parameterize_ruckig([0.0], [1e9], [1e-6], [1e-6], [1e-6])


# --------------------------------------------------------------------------------------------
# Selection, gripper, concatenation


def test_plan_timing_selects_the_method() -> None:
    limits = TimingLimits(VEL, ACC, JERK, speed_scale=0.8)
    toppra = plan_timing(PICK_WAYPOINTS, limits, "toppra")
    ruckig = plan_timing(PICK_WAYPOINTS, limits, "ruckig")
    assert (toppra.method, ruckig.method) == ("toppra", "ruckig")
    assert toppra.duration == pytest.approx(
        time_parameterize_toppra(PICK_WAYPOINTS, VEL, ACC, speed_scale=0.8).duration
    )
    with pytest.raises(ValueError, match="jerk"):
        plan_timing(PICK_WAYPOINTS, TimingLimits(VEL, ACC), "ruckig")
    with pytest.raises(ValueError, match="unknown timing"):
        plan_timing(PICK_WAYPOINTS, limits, "spline")  # type: ignore[arg-type]


def test_gripper_profile_respects_speed_and_minimum_duration() -> None:
    closing = gripper_trajectory(0.08, 0.0, max_speed=0.1)
    _, q, qd, _ = dense(closing)
    assert closing.joint_names == ("gripper",)
    assert q[0, 0] == 0.08 and q[-1, 0] == 0.0
    assert np.max(np.abs(qd)) <= 0.1 * (1 + 1e-9)
    assert np.max(np.abs(qd)) > 0.099  # reaches its speed on an 8 cm stroke
    slow = gripper_trajectory(0.08, 0.0, max_speed=0.1, min_duration=40 / 30)
    assert slow.duration == pytest.approx(40 / 30)


def test_concatenation_is_continuous_and_keeps_phases() -> None:
    names = [f"fr3_joint{i}" for i in range(1, 8)]
    pre_grasp, grasp = PICK_WAYPOINTS[2], PICK_WAYPOINTS[-1]
    lift = grasp + np.array([0.0, -0.05, 0.0, 0.08, 0.0, -0.03, 0.0])
    transport = time_parameterize_toppra(PICK_WAYPOINTS[:3], VEL, ACC, joint_names=names)
    approach = time_parameterize_ruckig(pre_grasp, grasp, VEL, ACC, JERK, joint_names=names)
    close = Trajectory.hold(grasp, 40 / 30, names)
    up = time_parameterize_toppra([grasp, lift], VEL, ACC, joint_names=names)
    plan = Trajectory.concatenate(
        [
            transport.with_label("transport"),
            approach.with_label("approach"),
            close.with_label("close"),
            up.with_label("lift"),
        ]
    )
    assert plan.method == "concat"
    assert plan.duration == pytest.approx(
        transport.duration + approach.duration + close.duration + up.duration
    )
    labels = [label for label, _, _ in plan.phases()]
    assert labels == ["transport", "approach", "close", "lift"]
    # Continuity: position continuous everywhere (velocity at rest at every boundary).
    ts, q, _qd, _ = dense(plan, 40001)
    step = np.max(np.abs(np.diff(q, axis=0)))
    assert step <= np.max(VEL) * (ts[1] - ts[0]) * (1 + 1e-6)
    for _, start, end in plan.phases():
        for t in (start, end):
            np.testing.assert_allclose(plan.sample(t)[1], 0.0, atol=1e-12)
    # Each piece plays unchanged at its offset.
    _, approach_start, _ = plan.phases()[1]
    local = np.linspace(0.0, approach.duration, 101)
    np.testing.assert_allclose(
        plan.sample_many(approach_start + local)[0], approach.sample_many(local)[0], atol=1e-12
    )
    np.testing.assert_array_equal(plan.end_position, lift)
    # A jump between pieces is refused; so are different joints.
    with pytest.raises(ValueError, match="starts"):
        Trajectory.concatenate([transport, up])
    with pytest.raises(ValueError, match="joints"):
        Trajectory.concatenate([transport, time_parameterize_toppra([pre_grasp, grasp], VEL, ACC)])


def test_time_grid_covers_the_duration() -> None:
    trajectory = time_parameterize_toppra(PICK_WAYPOINTS, VEL, ACC)
    grid = trajectory.time_grid(0.002)
    assert grid[0] == 0.0 and grid[-1] == pytest.approx(trajectory.duration)
    assert np.all(np.diff(grid) <= 0.002 + 1e-12)
