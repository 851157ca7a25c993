"""A stand-alone whole-body IK of one arm, posed at the robot's home (benchmarks, tests).

The arm's joints (the lift first, when the robot has one) are the active ones; the posture task
holds the robot.yaml home. The episode's planner builds its own IK with the scene's joint limits
(``PickPlanner``); this one uses the URDF's, which is what the IK benchmark and tests measure.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from harness.planning.ik import WholeBodyIK

if TYPE_CHECKING:
    from harness.robots.model import RobotModel


def arm_ik(robot: RobotModel, arm: str) -> tuple[WholeBodyIK, np.ndarray]:
    """The IK of ``arm`` and its home (active-joint order: lift, then the arm joints)."""
    spec = robot.arm(arm)
    active = ([robot.lift_joint] if robot.lift_joint else []) + list(spec.joints)
    ik = WholeBodyIK(robot.urdf_path, active, spec.ee_frame, robot.lift_joint)
    home = robot.home_configuration()
    ik.set_posture(home)
    return ik, np.array([home[j] for j in active])
