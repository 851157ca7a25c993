"""The whole-body IK of one arm of a robot, posed at the robot's home: the IK the episode's
planner solves with (``harness.episode.scene_cache``), and so what the IK benchmark measures.

The arm's joints (the lift first, when the robot has one) are the active ones, with the URDF's
joint limits; the posture task holds the robot.yaml home until the planner sets its own.
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
