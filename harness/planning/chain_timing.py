"""Timed segments of a chain plan: the joint-space transport and the Cartesian segments.

The executor plays a pick's plan (``ChainPlan``: transport, approach, lift, retreat) as timed
trajectories; this module times them, with the pick's timing choice for the transport and
TOP-RA for the dense Cartesian segments near the object.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from harness.config import TaskConfig
from harness.planning.plans import ChainPlan
from harness.planning.timing import (
    TimingLimits,
    Trajectory,
    plan_timing,
    time_parameterize_toppra,
)
from harness.robots import RobotModel
from harness.sim import Scene

TOPPRA_GRIDPOINTS = 30
# The Cartesian segments near the object (approach, lift, retreat) run at most at this fraction
# of the joint limits: time-optimal at full limits, the small arms' soft servos (kp 80, wrists
# 10) overshoot the grasp by up to a centimetre. At the reference's pace (speed_scale 0.3) every
# segment runs at 0.3, as the reference plays all of its plans at that pace.
CARTESIAN_SPEED_SCALE = 0.5


def task_timing_limits(robot: RobotModel, names: Sequence[str], task: TaskConfig) -> TimingLimits:
    """The timing limits of ``names`` for ``task``: robot.yaml's velocity, acceleration and
    jerk limits, the acceleration and jerk times the task's ``timing`` factors (the sweep keys
    of the chosen values, issue 55), at the task's ``speed_scale``."""
    acceleration, jerk = task.timing.factors(names, robot.lift_joint)
    return TimingLimits(
        robot.velocity_limits(names),
        robot.acceleration_limits(names) * acceleration,
        robot.jerk_limits(names) * jerk,
        task.pick.speed_scale,
    )


def time_plan(plan: ChainPlan, scene: Scene, arm: str, task: TaskConfig) -> dict[str, Trajectory]:
    """Timed segments of a chain plan. ``pick.timing`` times the joint-space transport; the
    Cartesian approach, lift and retreat always use TOPP-RA through their dense IK waypoints
    (offline Ruckig would stop at every waypoint), at ``speed_scale`` capped at
    ``CARTESIAN_SPEED_SCALE``."""
    names = scene.arms[arm].active_names
    limits = task_timing_limits(scene.robot, names, task)
    segments: dict[str, Trajectory] = {
        "transport": plan_timing(
            plan.transport, limits, task.pick.timing, names, "transport", TOPPRA_GRIDPOINTS
        )
    }

    def cartesian(waypoints: np.ndarray, label: str) -> Trajectory:
        return time_parameterize_toppra(
            waypoints,
            limits.velocity,
            limits.acceleration,
            min(limits.speed_scale, CARTESIAN_SPEED_SCALE),
            gridpoints=TOPPRA_GRIDPOINTS,
            joint_names=names,
            label=label,
        )

    segments["approach"] = cartesian(plan.approach, "approach")
    if plan.lift is not None:
        segments["lift"] = cartesian(plan.lift, "lift")
    if plan.retreat is not None:
        segments["retreat"] = cartesian(plan.retreat, "retreat")
    return segments
