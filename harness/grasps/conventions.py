"""Gripper conventions: how a robot's end-effector frame relates to GraspNet grasp axes.

A :class:`GripperConvention` is what post-processing (:mod:`harness.grasps.ee_poses`) and the
robot-neutral filters (:mod:`harness.grasps.filters`) need to know about a robot's gripper.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

AXES = ("x", "y", "z")


@dataclass(frozen=True)
class GripperConvention:
    """How a robot's end-effector frame relates to GraspNet grasp axes.

    ``R_ee_graspnet`` maps grasp axes to EE axes (``R_obj_ee = R_g @ R_ee_graspnet.T``);
    ``ee_axis`` is the EE axis the reference treats as the approach (``approach_axis`` is the
    same letter, named for the robot-neutral filters); ``facing_axis`` is the EE axis equal to
    -g_z, the one the canonical "forward 90" filters constrain.
    """

    R_ee_graspnet: np.ndarray
    ee_axis: str
    facing_axis: str
    tcp_offset: float
    gripper_min_width: float
    gripper_max_width: float

    def __post_init__(self) -> None:
        R = np.asarray(self.R_ee_graspnet, dtype=float)
        if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-9):
            raise ValueError("R_ee_graspnet must be a 3x3 rotation")
        if self.ee_axis not in AXES or self.facing_axis not in AXES:
            raise ValueError("ee_axis and facing_axis must be x, y or z")
        if self.ee_axis == self.facing_axis:
            raise ValueError("ee_axis and facing_axis must differ")
        object.__setattr__(self, "R_ee_graspnet", R)

    @property
    def approach_axis(self) -> str:
        return self.ee_axis

    @property
    def approach_index(self) -> int:
        return AXES.index(self.ee_axis)
