"""Robot facts read from ``robots/<name>/robot.yaml`` alone, without the URDF or a MuJoCo model.

Tools that need one fact of a robot (its grasp convention, its arms, its jaw opening, how
InternDataEngine files name it) read it here, so every robot fact lives in the robot's folder and
adding a robot is a folder and a YAML file. :class:`~harness.robots.model.RobotModel` is the full
model (yaml checked against the URDF) for simulation and planning.
"""

from __future__ import annotations

from functools import cache

import numpy as np

from harness.config import read_yaml, validate_model
from harness.config.robot_registry import available_robots, resolve_robot_yaml
from harness.grasps.conventions import GripperConvention
from harness.robots.spec import ConventionSpec, RobotFile
from harness.robots.validation import check_interndata_block


@cache
def robot_file(name: str) -> RobotFile:
    """The validated robot.yaml of a bundled robot (``fr3``) or a robot.yaml path."""
    doc = read_yaml(resolve_robot_yaml(name))
    spec = validate_model(RobotFile, doc.data, doc)
    check_interndata_block(spec, doc)
    return spec


def gripper_convention(spec: ConventionSpec) -> GripperConvention:
    """The grasp convention of a robot.yaml ``convention`` block."""
    return GripperConvention(
        R_ee_graspnet=np.asarray(spec.R_ee_graspnet, dtype=float),
        ee_axis=spec.ee_axis,
        facing_axis=spec.facing_axis,
        tcp_offset=spec.tcp_offset,
        gripper_min_width=spec.gripper_min_width,
        gripper_max_width=spec.gripper_max_width,
    )


def reference_convention(name: str) -> GripperConvention:
    """The robot's grasp convention (its reference robot config's values)."""
    return gripper_convention(robot_file(name).convention)


def robot_arms(name: str) -> tuple[str, ...]:
    """The robot's arm names (``left``, ``right``)."""
    return tuple(robot_file(name).arms)


def max_jaw_opening(name: str) -> float:
    """The widest jaw opening (m) over the robot's arms (``open_width``)."""
    return max(arm.open_width for arm in robot_file(name).arms.values())


def interndata_robots() -> dict[str, str]:
    """Reference robot config basename (``fr3.yaml``) -> bundled robot name, for every bundled
    robot whose robot.yaml has an ``interndata`` block."""
    names: dict[str, str] = {}
    for name in available_robots():
        spec = robot_file(name).interndata
        if spec is not None:
            names[spec.robot_config_file] = name
    return names


def interndata_home(name: str, arm: str) -> list[float]:
    """The arm's home in the reference robot config (``interndata.home``), or [] if not given."""
    spec = robot_file(name).interndata
    if spec is None or arm not in spec.home:
        return []
    return list(spec.home[arm])
