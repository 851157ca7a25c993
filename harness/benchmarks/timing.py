"""Benchmark section ``timing``: TOPP-RA and Ruckig time per trajectory, and sampling cost.

7 DoF with FR3-like limits (v = [2.62]*4 + [5.26, 4.18, 5.26] rad/s, a = 10 rad/s^2,
jerk = 5000 rad/s^3). Paths are realistic joint-space moves of a pick: a 2-waypoint straight
move (approach / lift), the 5-waypoint home -> pre-grasp -> grasp transport, and a 12-waypoint
path like an RRT-Connect result after shortcutting. Ruckig chains rest-to-rest segments through
the same waypoints (offline Ruckig has no intermediate waypoints), so its durations are longer;
both durations are reported as extras. Sampling is timed for a 500 Hz grid over the trajectory,
which is what the executor does per physics step.
"""

from __future__ import annotations

import numpy as np

from harness.benchmarks.framework import Figure, figure, time_call
from harness.benchmarks.machine import one_core
from harness.planning.timing import (
    Trajectory,
    ruckig_through,
    time_parameterize_ruckig,
    time_parameterize_toppra,
)

SECTION = "timing"
VEL = np.array([2.62, 2.62, 2.62, 2.62, 5.26, 4.18, 5.26])
ACC = np.full(7, 10.0)
JERK = np.full(7, 5000.0)
HOME = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])

# Target per TOPP-RA trajectory: a pick times about three paths within a 0.2 s episode budget.
TOPPRA_TARGET_MS = 10.0
RUCKIG_TARGET_MS = 0.2


def pick_waypoints() -> np.ndarray:
    """Home -> above the object -> pre-grasp -> grasp, as IK would give them."""
    return np.array(
        [
            HOME,
            [0.25, -0.45, 0.05, -2.20, 0.02, 1.75, 0.95],
            [0.40, -0.10, 0.08, -1.95, 0.03, 1.95, 1.10],
            [0.42, 0.05, 0.08, -1.95, 0.03, 2.00, 1.12],
            [0.43, 0.12, 0.08, -1.90, 0.03, 2.02, 1.13],
        ]
    )


def planner_waypoints(count: int = 12, seed: int = 0) -> np.ndarray:
    """A wandering joint path (RRT-like): a smooth drift plus bounded jitter, ``count`` points."""
    rng = np.random.default_rng(seed)
    goal = pick_waypoints()[-1]
    fractions = np.linspace(0.0, 1.0, count)[:, None]
    jitter = rng.normal(0.0, 0.15, (count, 7))
    jitter[[0, -1]] = 0.0
    return HOME + fractions * (goal - HOME) + jitter


def run(quick: bool) -> list[Figure]:
    with one_core():
        return _figures(quick)


def _figures(quick: bool) -> list[Figure]:
    reps = 20 if quick else 100
    pick = pick_waypoints()
    straight = pick[[0, -1]]
    planner = planner_waypoints()
    figures = _toppra_figures(reps, straight, pick, planner)
    figures.append(_ruckig_single_figure(reps, straight))
    toppra_pick = time_parameterize_toppra(pick, VEL, ACC)
    chained = ruckig_through(pick, VEL, ACC, JERK)
    figures.append(_ruckig_chained_figure(reps, pick, toppra_pick, chained))
    figures.extend(_sampling_figures(reps, toppra_pick, chained))
    return figures


def _toppra_figures(
    reps: int, straight: np.ndarray, pick: np.ndarray, planner: np.ndarray
) -> list[Figure]:
    """TOPP-RA time per trajectory, for each path and grid size."""
    figures: list[Figure] = []
    cases = (
        ("2 waypoints", straight, None, TOPPRA_TARGET_MS),
        ("5 waypoints", pick, None, TOPPRA_TARGET_MS),
        ("12 waypoints", planner, None, None),
        ("5 waypoints, 101 grid", pick, 101, TOPPRA_TARGET_MS),
        ("5 waypoints, 30 grid", pick, 30, TOPPRA_TARGET_MS),
        ("12 waypoints, 30 grid", planner, 30, None),
    )
    for name, waypoints, grid, target in cases:
        trajectory = time_parameterize_toppra(waypoints, VEL, ACC, gridpoints=grid)
        samples = time_call(
            lambda w=waypoints, g=grid: time_parameterize_toppra(w, VEL, ACC, gridpoints=g), reps
        )
        figures.append(
            figure(
                SECTION,
                f"TOPP-RA time per trajectory ({name})",
                samples,
                "ms",
                1e3,
                target=target,
                notes="7 DoF, FR3 limits, ParametrizeConstAccel, limits verified between grid "
                "points; cost grows with the grid (extra)",
                extra={
                    "trajectory_duration_s": trajectory.duration,
                    "gridpoints": len(trajectory.segments[0].profile.ss),  # type: ignore[attr-defined]
                },
            )
        )
    return figures


def _ruckig_single_figure(reps: int, straight: np.ndarray) -> Figure:
    """Ruckig time per rest-to-rest move along the straight path."""
    ruckig_single = time_parameterize_ruckig(straight[0], straight[1], VEL, ACC, JERK)
    samples = time_call(
        lambda: time_parameterize_ruckig(straight[0], straight[1], VEL, ACC, JERK), reps * 10
    )
    return figure(
        SECTION,
        "Ruckig time per rest-to-rest move",
        samples,
        "ms",
        1e3,
        target=RUCKIG_TARGET_MS,
        notes="7 DoF, Phase synchronisation (straight joint-space line), incl. Python setup",
        extra={"trajectory_duration_s": ruckig_single.duration},
    )


def _ruckig_chained_figure(
    reps: int, pick: np.ndarray, toppra_pick: Trajectory, chained: Trajectory
) -> Figure:
    """Ruckig chained through the pick's waypoints, its duration against TOPP-RA's in extra."""
    samples = time_call(lambda: ruckig_through(pick, VEL, ACC, JERK), reps)
    return figure(
        SECTION,
        "Ruckig chained through 5 waypoints",
        samples,
        "ms",
        1e3,
        notes="stops at every waypoint; duration ratio vs TOPP-RA on the same path in extra",
        extra={
            "trajectory_duration_s": chained.duration,
            "duration_ratio_vs_toppra": chained.duration / toppra_pick.duration,
        },
    )


def _sampling_figures(reps: int, toppra_pick: Trajectory, chained: Trajectory) -> list[Figure]:
    """Sampling cost of both trajectories on a 500 Hz grid."""
    figures: list[Figure] = []
    for label, trajectory in (("TOPP-RA", toppra_pick), ("Ruckig", chained)):
        grid = trajectory.time_grid(0.002)
        samples = time_call(lambda t=trajectory, g=grid: t.sample_many(g), reps)
        figures.append(
            figure(
                SECTION,
                f"{label} sampling at 500 Hz ({len(grid)} samples)",
                samples,
                "ms",
                1e3,
                notes="q, qd, qdd for the whole trajectory, vectorised sample_many",
            )
        )
    return figures
