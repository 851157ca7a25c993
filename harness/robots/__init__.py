"""Robots: ``robots/<name>/robot.yaml`` + URDF read into a validated :class:`RobotModel`.

``harness.robots.spec`` is the robot.yaml schema, ``urdf`` the URDF facts, ``validation`` the
checks of one against the other, ``registry`` finds bundled robots, ``model`` is the
:class:`RobotModel` and ``mujoco_spec`` builds its MuJoCo model.
"""

from harness.config.robot_registry import ROBOTS_DIR, available_robots, resolve_robot_yaml
from harness.robots.model import JointDynamics, RobotModel
from harness.robots.spec import ArmSpec, ConventionSpec, LiftSpec, RobotFile

__all__ = [
    "ROBOTS_DIR",
    "ArmSpec",
    "ConventionSpec",
    "JointDynamics",
    "LiftSpec",
    "RobotFile",
    "RobotModel",
    "available_robots",
    "resolve_robot_yaml",
]
