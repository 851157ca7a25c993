"""Time parameterisation of joint paths: TOPP-RA and Ruckig -> a ``Trajectory`` sampled by time.

Two methods, chosen per task by ``pick.timing`` (../shared/reference/libraries.md sections 4-5):

- **TOPP-RA** follows a geometric path through joint waypoints (a cubic spline over a
  chord-length path parameter, a straight line for two waypoints) as fast as the joint velocity
  and acceleration limits allow, starting and ending at rest. Jerk is unbounded (piecewise
  constant path acceleration).
- **Ruckig** computes jerk-limited rest-to-rest moves. With Phase synchronisation the path is the
  straight joint-space line between the two states. Offline Ruckig has no intermediate
  waypoints, so a waypoint list becomes a chain of rest-to-rest segments (it stops at every
  waypoint).

``speed_scale`` dilates time: velocity limits are multiplied by ``s``, accelerations by ``s**2``
and jerks by ``s**3``, so the same path is followed ``1/s`` times slower and every derivative
limit stays respected.

A ``Trajectory`` is a sequence of timed segments (transport, approach, lift, gripper moves, holds)
that the executor samples by time; ``Trajectory.concatenate`` plays several plans as one.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal, Protocol

import numpy as np
import ruckig
import toppra as ta
import toppra.algorithm as ta_algo
import toppra.constraint as ta_constraint
from toppra.algorithm.algorithm import ParameterizationReturnCode

TimingMethod = Literal["toppra", "ruckig"]

# Consecutive waypoints closer than this (max-norm, rad or m) are one waypoint.
DUPLICATE_TOLERANCE = 1e-9
# Concatenated segments must meet within this distance (max-norm).
CONTINUITY_TOLERANCE = 1e-6
# Automatic TOPP-RA grid: toppra's interpolation-error threshold, and a cap on the grid size.
GRID_MAX_ERROR = 1e-3
GRID_MAX_POINTS = 1000


class TimingError(RuntimeError):
    """Time parameterisation failed (the planner reports it as ``plan_failed``)."""

    def __init__(self, message: str, return_code: object = None) -> None:
        self.return_code = return_code
        super().__init__(message if return_code is None else f"{message} (code {return_code})")


Samples = tuple[np.ndarray, np.ndarray, np.ndarray]


class Profile(Protocol):
    """One timed piece: positions, velocities and accelerations at times in [0, duration]."""

    duration: float

    def evaluate(self, ts: np.ndarray) -> Samples:
        """``(q, qd, qdd)``, each ``(len(ts), dof)``, for times already clipped to the piece."""
        ...


# --------------------------------------------------------------------------------------------
# Profiles


@dataclass(frozen=True)
class HoldProfile:
    """Stand still at ``q`` for ``duration`` seconds."""

    q: np.ndarray
    duration: float

    def evaluate(self, ts: np.ndarray) -> Samples:
        n = len(ts)
        zeros = np.zeros((n, len(self.q)))
        return np.broadcast_to(self.q, (n, len(self.q))).copy(), zeros, zeros.copy()


class ConstAccelPathProfile:
    """A geometric path q(s) timed by TOP-RA's piecewise-constant path acceleration.

    The same maths as ``toppra.parametrizer.ParametrizeConstAccel`` (grid points ``s_i``,
    path velocities ``sd_i``; on each interval ``sdd`` is constant), evaluated vectorised:
    toppra's own evaluator loops in Python per sample. Endpoints are snapped exactly to the
    first and last waypoint, at rest.
    """

    def __init__(self, path: ta.SplineInterpolator, gridpoints: np.ndarray, sd: np.ndarray):
        self.path = path
        self.ss = np.asarray(gridpoints, dtype=float)
        self.sd = np.asarray(sd, dtype=float)
        self._derive()

    def _derive(self) -> None:
        ds = np.diff(self.ss)
        self.us = 0.5 * np.diff(self.sd**2) / ds  # path acceleration per interval
        with np.errstate(divide="ignore"):  # both ends at rest: infinite time, caught by caller
            dt = 2.0 * ds / (self.sd[:-1] + self.sd[1:])
        self.ts = np.concatenate([[0.0], np.cumsum(dt)])
        self.duration = float(self.ts[-1])
        # The spline reproduces its end waypoints only to rounding; snap to them exactly.
        waypoints = np.asarray(self.path.waypoints[1], dtype=float)
        self.q_start = waypoints[0]
        self.q_end = waypoints[-1]

    def limit_ratios(
        self, vel: np.ndarray, acc: np.ndarray, per_interval: int = 8
    ) -> tuple[float, float]:
        """Peak ``|qd| / vel`` and ``|qdd| / acc`` over ``per_interval`` samples per grid interval.

        TOPP-RA enforces the limits at the grid points only; between them the path derivatives
        change while ``sd**2`` is linear in ``s``, so the limits can be exceeded slightly.
        """
        fractions = np.linspace(0.0, 1.0, per_interval + 1)
        ds = np.diff(self.ss)
        interval = np.repeat(np.arange(len(ds)), len(fractions))
        s = (self.ss[:-1, None] + ds[:, None] * fractions[None, :]).reshape(-1)
        # The spline's knots, where q'' has kinks and peaks hide between samples.
        knots = np.asarray(self.path.waypoints[0], dtype=float)[1:-1]
        knot_interval = np.clip(np.searchsorted(self.ss, knots) - 1, 0, len(ds) - 1)
        s = np.concatenate([s, knots])
        interval = np.concatenate([interval, knot_interval])
        u = self.us[interval]
        sd_sq = np.maximum(self.sd[interval] ** 2 + 2.0 * u * (s - self.ss[interval]), 0.0)
        dq_ds = self.path(s, 1)
        qd = dq_ds * np.sqrt(sd_sq)[:, None]
        qdd = self.path(s, 2) * sd_sq[:, None] + dq_ds * u[:, None]
        return float(np.max(np.abs(qd) / vel)), float(np.max(np.abs(qdd) / acc))

    def dilate(self, factor: float) -> None:
        """Slow the whole profile down by ``factor`` >= 1: velocities / f, accelerations / f**2."""
        self.sd = self.sd / factor
        self._derive()

    def path_state(self, ts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Path position, velocity and acceleration ``(s, sd, sdd)`` at times ``ts``."""
        index = np.clip(np.searchsorted(self.ts, ts, side="right") - 1, 0, len(self.us) - 1)
        dt = ts - self.ts[index]
        u = self.us[index]
        v0 = self.sd[index]
        s = self.ss[index] + v0 * dt + 0.5 * u * dt**2
        return np.clip(s, self.ss[0], self.ss[-1]), v0 + u * dt, u

    def evaluate(self, ts: np.ndarray) -> Samples:
        s, sd, sdd = self.path_state(ts)
        dq_ds = self.path(s, 1)
        q = self.path(s)
        qd = dq_ds * sd[:, None]
        qdd = self.path(s, 2) * (sd**2)[:, None] + dq_ds * sdd[:, None]
        at_start = ts <= 0.0
        at_end = ts >= self.duration
        for mask, q_exact in ((at_start, self.q_start), (at_end, self.q_end)):
            if mask.any():
                q[mask] = q_exact
                qd[mask] = 0.0
                qdd[mask] = 0.0
        return q, qd, qdd


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


# --------------------------------------------------------------------------------------------
# Trajectory


@dataclass(frozen=True)
class Segment:
    """One timed piece of a trajectory, starting at ``start_time`` within it."""

    label: str
    method: str
    start_time: float
    profile: Profile

    @property
    def duration(self) -> float:
        return self.profile.duration

    @property
    def end_time(self) -> float:
        return self.start_time + self.profile.duration


@dataclass(frozen=True)
class Trajectory:
    """A timed joint trajectory made of consecutive segments; sample it with ``sample(t)``.

    Times outside ``[0, duration]`` are clipped, so sampling past the end holds the final
    position at rest. ``phases()`` names the segments (``transport``, ``approach``, ...), which
    the executor uses to know when the approach ends.
    """

    joint_names: tuple[str, ...]
    segments: tuple[Segment, ...]
    _starts: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not self.segments:
            raise ValueError("a Trajectory needs at least one segment")
        object.__setattr__(
            self, "_starts", np.array([segment.start_time for segment in self.segments])
        )

    # -- construction -------------------------------------------------------------------------

    @classmethod
    def from_profile(
        cls, profile: Profile, method: str, joint_names: Sequence[str] | None, label: str = ""
    ) -> Trajectory:
        q0, _, _ = profile.evaluate(np.zeros(1))
        names = _joint_names(joint_names, q0.shape[1])
        return cls(names, (Segment(label or method, method, 0.0, profile),))

    @classmethod
    def hold(
        cls,
        q: Sequence[float] | np.ndarray,
        duration: float,
        joint_names: Sequence[str] | None = None,
        label: str = "hold",
    ) -> Trajectory:
        """Stand still at ``q`` for ``duration`` seconds (>= 0)."""
        if not duration >= 0.0:
            raise ValueError(f"hold duration must be >= 0, got {duration}")
        q = _as_vector(q, "q")
        return cls.from_profile(HoldProfile(q, float(duration)), "hold", joint_names, label)

    @classmethod
    def concatenate(
        cls, parts: Sequence[Trajectory], tolerance: float = CONTINUITY_TOLERANCE
    ) -> Trajectory:
        """Play ``parts`` one after the other; each must start where the previous one ended."""
        if not parts:
            raise ValueError("concatenate needs at least one trajectory")
        names = parts[0].joint_names
        segments: list[Segment] = []
        offset = 0.0
        previous: Trajectory | None = None
        for index, part in enumerate(parts):
            if part.joint_names != names:
                raise ValueError(
                    f"trajectory {index} has joints {part.joint_names}, expected {names}"
                )
            if previous is not None:
                gap = float(np.max(np.abs(part.start_position - previous.end_position)))
                if gap > tolerance:
                    raise ValueError(
                        f"trajectory {index} starts {gap:.3g} away from where trajectory "
                        f"{index - 1} ends (tolerance {tolerance:g})"
                    )
            for segment in part.segments:
                segments.append(
                    Segment(
                        segment.label, segment.method, offset + segment.start_time, segment.profile
                    )
                )
            offset += part.duration
            previous = part
        return cls(names, tuple(segments))

    def with_label(self, label: str) -> Trajectory:
        """The same trajectory with every segment renamed ``label`` (e.g. ``"approach"``)."""
        segments = tuple(Segment(label, s.method, s.start_time, s.profile) for s in self.segments)
        return Trajectory(self.joint_names, segments)

    # -- properties ---------------------------------------------------------------------------

    @property
    def dof(self) -> int:
        return len(self.joint_names)

    @property
    def duration(self) -> float:
        return self.segments[-1].end_time

    @property
    def method(self) -> str:
        """``toppra`` / ``ruckig`` / ``hold`` for one method, ``concat`` for a mixture."""
        methods = {segment.method for segment in self.segments}
        return methods.pop() if len(methods) == 1 else "concat"

    @property
    def start_position(self) -> np.ndarray:
        return self.sample(0.0)[0]

    @property
    def end_position(self) -> np.ndarray:
        return self.sample(self.duration)[0]

    def phases(self) -> list[tuple[str, float, float]]:
        """``(label, start, end)`` per run of equally labelled segments, in time order."""
        out: list[tuple[str, float, float]] = []
        for segment in self.segments:
            if out and out[-1][0] == segment.label:
                out[-1] = (segment.label, out[-1][1], segment.end_time)
            else:
                out.append((segment.label, segment.start_time, segment.end_time))
        return out

    # -- sampling -----------------------------------------------------------------------------

    def sample(self, t: float) -> Samples:
        """``(q, qd, qdd)`` at time ``t`` (clipped to ``[0, duration]``), each ``(dof,)``."""
        q, qd, qdd = self.sample_many(np.array([t], dtype=float))
        return q[0], qd[0], qdd[0]

    def sample_many(self, ts: Sequence[float] | np.ndarray) -> Samples:
        """Vectorised ``sample``: each output is ``(len(ts), dof)``."""
        ts = np.clip(np.asarray(ts, dtype=float).reshape(-1), 0.0, self.duration)
        q = np.empty((len(ts), self.dof))
        qd = np.empty_like(q)
        qdd = np.empty_like(q)
        # A time on a boundary belongs to the later segment; zero-length segments never win
        # except at the very end, where the last segment is used.
        index = np.searchsorted(self._starts, ts, side="right") - 1
        index = np.clip(index, 0, len(self.segments) - 1)
        for seg_index in np.unique(index):
            rows = index == seg_index
            segment = self.segments[seg_index]
            local = np.clip(ts[rows] - segment.start_time, 0.0, segment.duration)
            q[rows], qd[rows], qdd[rows] = segment.profile.evaluate(local)
        return q, qd, qdd

    def time_grid(self, dt: float) -> np.ndarray:
        """Times ``0, dt, 2 dt, ...`` up to and including ``duration``."""
        count = int(np.floor(self.duration / dt + 1e-9)) + 1
        ts = np.arange(count) * dt
        return ts if np.isclose(ts[-1], self.duration) else np.append(ts, self.duration)


# --------------------------------------------------------------------------------------------
# Limits


@dataclass(frozen=True)
class TimingLimits:
    """Per-joint velocity, acceleration and jerk limits (positive) and a speed scale in (0, 1]."""

    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray | None = None
    speed_scale: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "velocity", _positive(self.velocity, "velocity"))
        object.__setattr__(self, "acceleration", _positive(self.acceleration, "acceleration"))
        if self.jerk is not None:
            object.__setattr__(self, "jerk", _positive(self.jerk, "jerk"))
        for name in ("acceleration", "jerk"):
            value = getattr(self, name)
            if value is not None and value.shape != self.velocity.shape:
                raise ValueError(
                    f"{name} limits have shape {value.shape}, velocity {self.velocity.shape}"
                )
        _check_scale(self.speed_scale)

    @property
    def dof(self) -> int:
        return len(self.velocity)

    def scaled(self) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Velocity, acceleration and jerk limits after applying ``speed_scale``."""
        return _scale_limits(self.velocity, self.acceleration, self.jerk, self.speed_scale)


# --------------------------------------------------------------------------------------------
# TOPP-RA


def time_parameterize_toppra(
    waypoints: Sequence[Sequence[float]] | np.ndarray,
    vel_limits: Sequence[float] | np.ndarray,
    acc_limits: Sequence[float] | np.ndarray,
    speed_scale: float = 1.0,
    gridpoints: int | None = None,
    joint_names: Sequence[str] | None = None,
    label: str = "",
) -> Trajectory:
    """Time-optimal rest-to-rest trajectory along the spline through ``waypoints`` (K, dof).

    Consecutive duplicate waypoints are dropped; if nothing moves the result is a zero-length
    hold. Two waypoints give a straight joint-space line; more give a not-a-knot cubic spline
    over the normalised cumulative chord length (so collinear waypoints stay on their line).
    ``gridpoints`` = number of TOPP-RA grid points (None: toppra's automatic grid).
    Raises ``TimingError`` with toppra's return code when no parameterisation exists.
    """
    points = _waypoints(waypoints)
    vel, acc, _ = _scale_limits(
        _positive(vel_limits, "vel_limits"), _positive(acc_limits, "acc_limits"), None, speed_scale
    )
    _check_dof(points, vel, acc)
    points = _drop_duplicates(points)
    names = _joint_names(joint_names, points.shape[1])
    if len(points) == 1:
        return Trajectory.hold(points[0], 0.0, names, label=label or "toppra")

    chord = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    s_waypoints = chord / chord[-1]
    s_waypoints[-1] = 1.0
    path = ta.SplineInterpolator(s_waypoints, points)  # 2 points: scipy makes it a line
    constraints = [
        ta_constraint.JointVelocityConstraint(np.stack([-vel, vel], axis=1)),
        ta_constraint.JointAccelerationConstraint(np.stack([-acc, acc], axis=1)),
    ]
    if gridpoints is None:
        grid = propose_grid(path)
    elif int(gridpoints) >= 2:
        grid = np.linspace(0.0, 1.0, int(gridpoints))
    else:
        raise ValueError(f"gridpoints must be >= 2, got {gridpoints}")
    instance = ta_algo.TOPPRA(
        constraints, path, gridpoints=grid, parametrizer="ParametrizeConstAccel"
    )
    # ``compute_trajectory`` = this + building toppra's (Python-loop) ConstAccel evaluator,
    # which ConstAccelPathProfile replaces; it returns None exactly when the code is not Ok.
    with np.errstate(divide="ignore", invalid="ignore"):  # degenerate grids: checked below
        instance.compute_parameterization(0.0, 0.0)
    data = instance.problem_data
    if data.return_code != ParameterizationReturnCode.Ok:
        raise TimingError(
            "TOPP-RA found no feasible parameterisation of the path", data.return_code
        )
    profile = ConstAccelPathProfile(path, data.gridpoints, data.sd_vec)
    if not np.isfinite(profile.duration):
        raise TimingError("TOPP-RA left the path at rest on a grid interval (too few grid points?)")
    vel_ratio, acc_ratio = profile.limit_ratios(vel, acc)
    dilation = max(vel_ratio, float(np.sqrt(acc_ratio)))
    if dilation > 1.0:
        profile.dilate(dilation * (1.0 + 1e-9))
    return Trajectory.from_profile(profile, "toppra", names, label)


def propose_grid(
    path: ta.SplineInterpolator,
    max_error: float = GRID_MAX_ERROR,
    max_step: float = 0.05,
    min_points: int = 100,
    max_points: int = GRID_MAX_POINTS,
) -> np.ndarray:
    """TOPP-RA grid over s in [0, 1]: the spline knots, bisected where the path bends.

    toppra's ``propose_gridpoints`` criterion (an interval is split while
    ``0.5 * max|q''(mid)| * ds**2 > max_error`` or ``ds > max_step``), vectorised and capped at
    ``max_points``: toppra's own version loops in Python and, on a path with extreme curvature,
    doubles its grid until memory runs out.
    """
    grid = np.unique(np.concatenate([np.asarray(path.waypoints[0], dtype=float), [0.0, 1.0]]))
    while len(grid) < max_points:
        ds = np.diff(grid)
        mid = grid[:-1] + 0.5 * ds
        error = 0.5 * np.max(np.abs(path(mid, 2)), axis=1) * ds**2
        split = (error > max_error) | (ds > max_step)
        if not split.any():
            break
        room = max_points - len(grid)
        if split.sum() > room:  # split the worst intervals only
            worst = np.argsort(-np.where(split, error + (ds > max_step), -1.0))[:room]
            split = np.zeros_like(split)
            split[worst] = True
        grid = np.sort(np.concatenate([grid, mid[split]]))
    while len(grid) < min_points:
        grid = np.sort(np.concatenate([grid, grid[:-1] + 0.5 * np.diff(grid)]))
    return grid


# --------------------------------------------------------------------------------------------
# Ruckig


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
    q_start = _as_vector(start, "start")
    q_goal = _as_vector(goal, "goal")
    v, a, j = _scale_limits(
        _positive(vel, "vel"), _positive(acc, "acc"), _positive(jerk, "jerk"), speed_scale
    )
    dof = len(q_start)
    if not (len(q_goal) == dof == len(v) == len(a) == len(j)):  # type: ignore[arg-type]
        raise ValueError(
            f"start {len(q_start)}, goal {len(q_goal)} and limits ({len(v)}, {len(a)}, "
            f"{len(j)}) must have the same length"  # type: ignore[arg-type]
        )
    names = _joint_names(joint_names, dof)
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
    points = _drop_duplicates(_waypoints(waypoints))
    names = _joint_names(joint_names, points.shape[1])
    if len(points) == 1:
        return Trajectory.hold(points[0], 0.0, names, label=label or "ruckig")
    parts = [
        time_parameterize_ruckig(a, b, vel, acc, jerk, speed_scale, names, label)
        for a, b in itertools.pairwise(points)
    ]
    return Trajectory.concatenate(parts)


# --------------------------------------------------------------------------------------------
# Selection and gripper


def plan_timing(
    waypoints: Sequence[Sequence[float]] | np.ndarray,
    limits: TimingLimits,
    method: TimingMethod = "toppra",
    joint_names: Sequence[str] | None = None,
    label: str = "",
    gridpoints: int | None = None,
) -> Trajectory:
    """Time ``waypoints`` with the method named by ``pick.timing`` (``toppra`` | ``ruckig``)."""
    if method == "toppra":
        return time_parameterize_toppra(
            waypoints,
            limits.velocity,
            limits.acceleration,
            limits.speed_scale,
            gridpoints=gridpoints,
            joint_names=joint_names,
            label=label,
        )
    if method == "ruckig":
        if limits.jerk is None:
            raise ValueError("timing 'ruckig' needs jerk limits")
        return ruckig_through(
            waypoints,
            limits.velocity,
            limits.acceleration,
            limits.jerk,
            limits.speed_scale,
            joint_names=joint_names,
            label=label,
        )
    raise ValueError(f"unknown timing method {method!r}; expected 'toppra' or 'ruckig'")


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


# --------------------------------------------------------------------------------------------
# Helpers


def _as_vector(values: Sequence[float] | np.ndarray, name: str) -> np.ndarray:
    vector = np.asarray(values, dtype=float).reshape(-1)
    if vector.size == 0 or not np.all(np.isfinite(vector)):
        raise ValueError(f"{name} must be a non-empty finite vector, got {values!r}")
    return vector


def _positive(values: Sequence[float] | np.ndarray, name: str) -> np.ndarray:
    vector = _as_vector(values, name)
    if np.any(vector <= 0.0):
        raise ValueError(f"{name} must be positive, got {vector.tolist()}")
    return vector


def _check_scale(speed_scale: float) -> None:
    if not (np.isfinite(speed_scale) and 0.0 < speed_scale <= 1.0):
        raise ValueError(f"speed_scale must be in (0, 1], got {speed_scale}")


def _scale_limits(
    vel: np.ndarray, acc: np.ndarray, jerk: np.ndarray | None, speed_scale: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    _check_scale(speed_scale)
    s = float(speed_scale)
    return vel * s, acc * s**2, None if jerk is None else jerk * s**3


def _waypoints(waypoints: Sequence[Sequence[float]] | np.ndarray) -> np.ndarray:
    points = np.asarray(waypoints, dtype=float)
    if points.ndim != 2 or points.shape[0] < 1 or points.shape[1] < 1:
        raise ValueError(f"waypoints must have shape (K, dof), got {points.shape}")
    if not np.all(np.isfinite(points)):
        raise ValueError("waypoints contain NaN or infinite values")
    return points


def _check_dof(points: np.ndarray, *limits: np.ndarray) -> None:
    for limit in limits:
        if limit.shape != (points.shape[1],):
            raise ValueError(
                f"limits have {limit.shape[0]} values, waypoints {points.shape[1]} DoF"
            )


def _drop_duplicates(points: np.ndarray) -> np.ndarray:
    keep = [0]
    for index in range(1, len(points)):
        if np.max(np.abs(points[index] - points[keep[-1]])) > DUPLICATE_TOLERANCE:
            keep.append(index)
    if len(keep) > 1 and keep[-1] != len(points) - 1:
        keep[-1] = len(points) - 1  # end exactly on the last waypoint given
    return points[keep]


def _joint_names(joint_names: Sequence[str] | None, dof: int) -> tuple[str, ...]:
    if joint_names is None:
        return tuple(f"joint{i}" for i in range(dof))
    names = tuple(joint_names)
    if len(names) != dof:
        raise ValueError(f"{len(names)} joint names for {dof} DoF")
    return names
