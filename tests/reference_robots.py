"""What the tests pin about the reference's three robots: their conventions, frames, masses,
placements, widths and fingertips, from the reference configs and the cited sources.

This is the one test module that may name the bundled robots as a set (``tests/test_structure.py``
checks it): every other test takes its robot list from the registry (``tests/helpers.py``) and
looks a robot's pinned facts up here with :func:`pinned`, which skips a robot that has none. A
fourth robot is thereby covered by every generic test without an edit here; pinning its own facts
here is optional.
"""

from __future__ import annotations

from typing import TypeVar

import numpy as np
import pytest

from harness.grasps import GripperConvention

T = TypeVar("T")

REFERENCE_ROBOTS = ("fr3", "lift2", "split_aloha")
"""The InternDataEngine robots (fr3.yaml, lift2.yaml, split_aloha.yaml) this harness reproduces."""


def pinned(table: dict[str, T], robot: str) -> T:
    """``table[robot]``; skips the test for a robot whose facts are not pinned here."""
    if robot not in table:
        pytest.skip(f"{robot}: no pinned facts in tests/reference_robots.py (generic tests only)")
    return table[robot]


# The reference robot configs' grasp conventions (InternDataEngine fr3.yaml, lift2.yaml,
# split_aloha.yaml; docs/reference-pick-skill.md section 3), written out here as the expected
# values that robots/<name>/robot.yaml must reproduce.
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

# The reference's robot config file per robot (the ``robot_config_file`` basename).
INTERNDATA_CONFIG_FILES = {
    "fr3": "fr3.yaml",
    "lift2": "lift2.yaml",
    "split_aloha": "split_aloha.yaml",
}

# Arms, and the reference EE link each arm's EE frame is named after (``<arm>_<link>``).
ARM_NAMES = {"fr3": ["left"], "lift2": ["left", "right"], "split_aloha": ["left", "right"]}
EE_LINKS = {"fr3": "hand", "lift2": "link6", "split_aloha": "link6"}

# Arm bases in the robot's root frame as the reference has them (issue 22): x, y from its
# LeRobot converters (policy/lmdb2lerobotv21/lmdb2lerobot_{split_aloha,lift2}_a1.py lines
# 382-385, armbase_to_robot_pose); heights: the Cobot Magic fixture's 0.782 (split_aloha) and
# lift2.urdf at the lift home 0.46 (0.27 + 0.46 + 0.0245); robots/<name>/build.py says why the
# converters' z is not used.
REFERENCE_ARM_BASES = {
    "split_aloha": {
        "left": (0.3684792, 0.30600064, 0.782),
        "right": (0.36847978, -0.30599953, 0.782),
    },
    "lift2": {
        "left": (0.163030156, 0.248420062, 0.7545),
        "right": (0.163030139, -0.248420087, 0.7545),
    },
}

# Left minus right arm base y (m) of the two-armed robots: the converters' (above), as built.
ARM_SPACING = {"lift2": 2 * 0.24842, "split_aloha": 2 * 0.306}

# Jaw opening (m): the reference's gripper_max_width (Split ALOHA: its piper100; the SDK's
# 0.07 is the sdk070 variant).
OPEN_WIDTHS = {"fr3": 0.08, "lift2": 0.088, "split_aloha": 0.10}

# TCP frame past the EE frame (m): Franka's 0.1034 (the reference's tcp_offset 0.1043 is a digit
# swap, kept in the convention), the Piper's 0.12, the R5a's 0.125.
TCP_FRAME_OFFSET = {"fr3": 0.1034, "split_aloha": 0.12, "lift2": 0.125}

# Where the approach axis points at home, in the arm base frame: fr3 down, split_aloha forward
# and 15 deg down, lift2 straight forward.
APPROACH_AT_HOME = {
    "fr3": np.array([-0.057, 0.0, -0.998]),
    "split_aloha": np.array([0.967, 0.007, -0.256]),
    "lift2": np.array([1.0, 0.0, 0.002]),
}

# Placement (the reference's A-on-B offsets): the root's y range and z range in the world.
PLACEMENTS = {
    "fr3": ((-0.495, -0.445), (0.0, 0.05)),
    "lift2": ((-0.80, -0.80), (-0.775, -0.67)),
    "split_aloha": ((-0.86, -0.86), (-0.765, -0.715)),
}

# Link masses (kg) of the URDFs: FR3 inertials.yaml (+ Panda hand and fingers), Piper and R5a
# URDF masses (one arm; the other is the same), the Lift-2 base and carriage.
_FR3_MASSES = (2.397, 2.927, 2.936, 2.245, 2.616, 2.327, 1.817, 0.627)
_PIPER_MASSES = (1.02, 0.71, 1.17, 0.5, 0.38, 0.383)
_R5A_MASSES = (0.423, 0.097, 1.199, 0.841, 0.124, 0.636, 0.441)
LINK_MASSES = {
    "fr3": {
        **{f"left_link{i}": m for i, m in enumerate(_FR3_MASSES)},
        "left_hand": 0.73,
        "left_leftfinger": 0.015,
    },
    "split_aloha": {
        f"right_{name}": m
        for name, m in zip(
            ["base_link"] + [f"link{i}" for i in range(1, 6)], _PIPER_MASSES, strict=True
        )
    },
    "lift2": {
        **{
            f"left_{name}": m
            for name, m in zip(
                ["base_link"] + [f"link{i}" for i in range(1, 7)], _R5A_MASSES, strict=True
            )
        },
        "base": 21.0,
        "lift_link": 14.2,
    },
}

# Fingertip (farthest finger collision point along the approach axis) past the EE frame, from
# the cited sources (robots/<name>/robot.yaml comments):
FINGERTIP_M = {
    # Franka Hand rubber tip: pad centre 0.1037 past the hand, 18.5 mm tall (Menagerie
    # franka_emika_panda/panda.xml fingertip pads; finger roots at 0.0584).
    "fr3": 0.1037 + 0.0185 / 2,
    # The reference's gripper keypoint tool_head (InternDataEngine lift2.yaml: link6 x 0.135;
    # split_aloha.yaml: link6 z 0.12). Menagerie's pads would reach 0.15657 and 0.13503.
    "lift2": 0.135,
    "split_aloha": 0.12,
}

# The reference's cuRobo planner files per robot: the pre-grasp backs off along EE column 0
# when "r5a" is in the file name, else column 2 (quirk 14).
REFERENCE_PLANNER_FILES = {
    "fr3": ["fr3_left_arm.yml"],
    "lift2": ["r5a_left_arm.yml", "r5a_right_arm.yml"],
    "split_aloha": ["piper100_left_arm.yml", "piper100_right_arm.yml"],
}

# EE axes (x, y, z) of a top-down grasp in GraspNet terms (docs/reference-pick-skill.md section
# 3, "EE axes in GraspNet terms") and, for the flipped copy, the same turned 180 deg about the
# approach axis: ``-z`` is -g_z.
EE_AXES_IN_GRASPNET = {
    "fr3": (("-z", "y", "x"), ("z", "-y", "x")),  # flip about z
    "lift2": (("x", "-y", "-z"), ("x", "y", "z")),  # flip about x
    "split_aloha": (("-y", "-z", "x"), ("y", "z", "x")),  # flip about z
}

# The fuzz test's arms whose canonical direction filter is downward 140 on EE z or that accept
# it (chosen; see tests/test_fuzz_inputs.py).
FUZZ_CLEAN_ARMS = [
    ("fr3", "left"),
    ("split_aloha", "left"),
    ("split_aloha", "right"),
    ("lift2", "right"),
]
