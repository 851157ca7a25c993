"""Ruckig: jerk-limited rest-to-rest moves on straight joint-space lines.

**Ruckig** computes jerk-limited rest-to-rest moves. With Phase synchronisation the path is the
straight joint-space line between the two states. Offline Ruckig has no intermediate
waypoints, so a waypoint list becomes a chain of rest-to-rest segments (it stops at every
waypoint). The gripper's opening and closing are 1-DoF Ruckig moves.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence

import numpy as np
import ruckig

from harness.planning.timing.errors import TimingError
from harness.planning.timing.inputs import (
    as_vector,
    drop_duplicates,
    positive_vector,
    resolve_joint_names,
    scale_limits,
    waypoint_array,
)
from harness.planning.timing.trajectory import Samples, Trajectory


class RuckigProfile:
    """A Ruckig rest-to-rest trajectory; the end is snapped exactly to the goal, at rest."""

    def __init__(self, trajectory: ruckig.Trajectory, goal: np.ndarray) -> None:
        self.trajectory = trajectory
        self.duration = float(trajectory.duration)
        self.goal = np.asarray(goal, dtype=float)

    def evaluate(self, ts: np.ndarray) -> Samples:
        dof = len(self.goal)
        q = np.empty((len(ts), dof))
        qd = np.empty_like(q)
        qdd = np.empty_like(q)
        at_time = self.trajectory.at_time
        for row, t in enumerate(ts):
            if t >= self.duration:
                q[row], qd[row], qdd[row] = self.goal, 0.0, 0.0
            else:
                q[row], qd[row], qdd[row] = at_time(float(t))
        return q, qd, qdd


def time_parameterize_ruckig(
    start: Sequence[float] | np.ndarray,
    goal: Sequence[float] | np.ndarray,
    vel: Sequence[float] | np.ndarray,
    acc: Sequence[float] | np.ndarray,
    jerk: Sequence[float] | np.ndarray,
    speed_scale: float = 1.0,
    joint_names: Sequence[str] | None = None,
    label: str = "",
    min_duration: float | None = None,
) -> Trajectory:
    """Jerk-limited, time-optimal rest-to-rest move on the straight joint-space line.

    Phase synchronisation makes every joint follow the same normalised profile, so the path is
    the segment ``start -> goal``. ``min_duration`` stretches the move to last at least that
    long. Raises ``TimingError`` unless Ruckig returns ``Result.Working``.
    """
    q_start = as_vector(start, "start")
    q_goal = as_vector(goal, "goal")
    v, a, j = scale_limits(
        positive_vector(vel, "vel"),
        positive_vector(acc, "acc"),
        positive_vector(jerk, "jerk"),
        speed_scale,
    )
    dof = len(q_start)
    if not (len(q_goal) == dof == len(v) == len(a) == len(j)):  # type: ignore[arg-type]
        raise ValueError(
            f"start {len(q_start)}, goal {len(q_goal)} and limits ({len(v)}, {len(a)}, "
            f"{len(j)}) must have the same length"  # type: ignore[arg-type]
        )
    names = resolve_joint_names(joint_names, dof)
    inp = ruckig.InputParameter(dof)
    inp.current_position = q_start.tolist()
    inp.target_position = q_goal.tolist()
    inp.max_velocity = v.tolist()
    inp.max_acceleration = a.tolist()
    inp.max_jerk = j.tolist()  # type: ignore[union-attr]
    inp.synchronization = ruckig.Synchronization.Phase
    if min_duration is not None:
        inp.minimum_duration = float(min_duration)
    trajectory = ruckig.Trajectory(dof)
    try:
        result = ruckig.Ruckig(dof).calculate(inp, trajectory)
    except ruckig.RuckigError as exc:
        message = f"Ruckig rejected the input: {str(exc).strip()}"
        raise TimingError(message, "ErrorInvalidInput") from exc
    if result != ruckig.Result.Working:
        raise TimingError("Ruckig found no trajectory", getattr(result, "name", result))
    return Trajectory.from_profile(RuckigProfile(trajectory, q_goal), "ruckig", names, label)


def ruckig_through(
    waypoints: Sequence[Sequence[float]] | np.ndarray,
    vel: Sequence[float] | np.ndarray,
    acc: Sequence[float] | np.ndarray,
    jerk: Sequence[float] | np.ndarray,
    speed_scale: float = 1.0,
    joint_names: Sequence[str] | None = None,
    label: str = "",
) -> Trajectory:
    """Rest-to-rest Ruckig segments through every waypoint, chained (stops at each waypoint).

    Offline Ruckig cannot pass through intermediate waypoints (that needs Ruckig Pro), so the
    path is piecewise straight and the arm halts at each corner.
    """
    points = drop_duplicates(waypoint_array(waypoints))
    names = resolve_joint_names(joint_names, points.shape[1])
    if len(points) == 1:
        return Trajectory.hold(points[0], 0.0, names, label=label or "ruckig")
    parts = [
        time_parameterize_ruckig(a, b, vel, acc, jerk, speed_scale, names, label)
        for a, b in itertools.pairwise(points)
    ]
    return Trajectory.concatenate(parts)


def gripper_trajectory(
    start_opening: float,
    goal_opening: float,
    max_speed: float,
    max_acceleration: float | None = None,
    max_jerk: float | None = None,
    min_duration: float | None = None,
    joint_name: str = "gripper",
    label: str = "gripper",
) -> Trajectory:
    """1-DoF Ruckig profile for a finger-opening change limited by the gripper's speed.

    Defaults: the gripper reaches ``max_speed`` in 50 ms (acceleration ``20 * max_speed``) with
    jerk ``20 * acceleration``. ``min_duration`` lets the close take the reference's
    ``gripper_change_steps * control_dt``.
    """
    acc = max_acceleration if max_acceleration is not None else 20.0 * max_speed
    jerk = max_jerk if max_jerk is not None else 20.0 * acc
    return time_parameterize_ruckig(
        [start_opening],
        [goal_opening],
        [max_speed],
        [acc],
        [jerk],
        joint_names=[joint_name],
        label=label,
        min_duration=min_duration,
    )
