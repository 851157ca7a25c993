"""Reference gripper conventions of the three project robots (pick-skill.md section 3).

Kept apart from :mod:`harness.grasps.conventions`: these are robot facts, and
``robots/<name>/robot.yaml`` is their source of truth at run time.
"""

from __future__ import annotations

import numpy as np

from harness.grasps.conventions import GripperConvention

# Reference values (pick-skill.md section 3) for the three project robots. robots/<name>/robot.yaml
# is the source of truth at run time; these serve tests and tools that run without a robot model.
REFERENCE_CONVENTIONS: dict[str, GripperConvention] = {
    "fr3": GripperConvention(
        R_ee_graspnet=np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]),
        ee_axis="z",
        facing_axis="x",
        tcp_offset=0.1043,
        gripper_min_width=0.0,
        gripper_max_width=0.08,
    ),
    "lift2": GripperConvention(
        R_ee_graspnet=np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]),
        ee_axis="x",
        facing_axis="z",
        tcp_offset=0.125,
        gripper_min_width=0.0,
        gripper_max_width=0.088,
    ),
    "split_aloha": GripperConvention(
        R_ee_graspnet=np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]),
        ee_axis="z",
        facing_axis="y",
        tcp_offset=0.12,
        gripper_min_width=0.0,
        gripper_max_width=0.10,
    ),
}
