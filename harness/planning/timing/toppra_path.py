"""TOPP-RA: time-optimal timing of a geometric path through joint waypoints.

**TOPP-RA** follows a geometric path through joint waypoints (a cubic spline over a
chord-length path parameter, a straight line for two waypoints) as fast as the joint velocity
and acceleration limits allow, starting and ending at rest. Jerk is unbounded (piecewise
constant path acceleration).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from typing import Any, cast

import numpy as np
import toppra as ta
import toppra.algorithm as ta_algo
import toppra.constraint as ta_constraint
import toppra.solverwrapper as ta_solverwrapper
from toppra.algorithm.algorithm import ParameterizationReturnCode

from harness.planning.timing.errors import TimingError
from harness.planning.timing.inputs import (
    check_dof,
    drop_duplicates,
    positive_vector,
    resolve_joint_names,
    scale_limits,
    waypoint_array,
)
from harness.planning.timing.trajectory import Samples, Trajectory

# Automatic TOPP-RA grid: toppra's interpolation-error threshold, and a cap on the grid size.
GRID_MAX_ERROR = 1e-3
GRID_MAX_POINTS = 1000

# Every TOPPRA instance asks ``available_solvers`` which optional solvers are installed: two
# ``importlib`` searches of sys.path, ~0.15 ms each, six per episode (three timed paths). The
# answer cannot change while the process runs, so it is asked once; the solver it leads to
# (``seidel``, first and always available) is the same.
ta_solverwrapper.available_solvers = functools.cache(ta_solverwrapper.available_solvers)


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
    points = waypoint_array(waypoints)
    vel, acc, _ = scale_limits(
        positive_vector(vel_limits, "vel_limits"),
        positive_vector(acc_limits, "acc_limits"),
        None,
        speed_scale,
    )
    check_dof(points, vel, acc)
    points = drop_duplicates(points)
    names = resolve_joint_names(joint_names, points.shape[1])
    if len(points) == 1:
        return Trajectory.hold(points[0], 0.0, names, label=label or "toppra")

    chord = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    s_waypoints = chord / chord[-1]
    s_waypoints[-1] = 1.0
    path = ta.SplineInterpolator(s_waypoints, points)  # 2 points: scipy makes it a line
    constraints = list(_limit_constraints(tuple(vel.tolist()), tuple(acc.tolist())))
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
    # toppra types these Optional: they are set once the parameterisation succeeded (checked).
    grid_s = cast(np.ndarray, data.gridpoints)
    grid_sd = cast(np.ndarray, data.sd_vec)
    profile = ConstAccelPathProfile(path, grid_s, grid_sd)
    if not np.isfinite(profile.duration):
        raise TimingError("TOPP-RA left the path at rest on a grid interval (too few grid points?)")
    vel_ratio, acc_ratio = profile.limit_ratios(vel, acc)
    dilation = max(vel_ratio, float(np.sqrt(acc_ratio)))
    if dilation > 1.0:
        profile.dilate(dilation * (1.0 + 1e-9))
    return Trajectory.from_profile(profile, "toppra", names, label)


@functools.lru_cache(maxsize=64)
def _limit_constraints(vel: tuple[float, ...], acc: tuple[float, ...]) -> tuple[Any, Any]:
    """toppra's joint velocity and acceleration constraints for these limits, made once per
    limits: the algorithm only reads them, and their constructors format every limit into a
    description string (~3.7 ms of an FR3 episode's planning: three timed paths)."""
    v, a = np.asarray(vel), np.asarray(acc)
    return (
        ta_constraint.JointVelocityConstraint(np.stack([-v, v], axis=1)),
        ta_constraint.JointAccelerationConstraint(np.stack([-a, a], axis=1)),
    )


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
