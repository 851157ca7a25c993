"""Videos look at the gripper and the object from the side, the arm out of the line of sight
(issue 56: a grey link filled the frame of FR3's slip and table-penetration videos, Split
ALOHA's forearm the foreground of its plan failures)."""

from __future__ import annotations

import numpy as np
import pytest

from harness.viz.video import FRONT_DEG, side_azimuth


def camera_direction(azimuth_deg: float) -> np.ndarray:
    """Where the camera stands from what it looks at (MuJoCo: azimuth is the view direction)."""
    a = np.radians(azimuth_deg)
    return -np.array([np.cos(a), np.sin(a)])


def angle_deg(u: np.ndarray, v: np.ndarray) -> float:
    return float(np.degrees(np.arccos(u @ v / np.linalg.norm(u) / np.linalg.norm(v))))


@pytest.mark.parametrize("reach", [(0.0, 1.0), (1.0, 0.0), (-0.6, 0.8), (0.3, -0.9)])
def test_the_camera_stands_across_the_reach_past_the_object(reach: tuple[float, float]) -> None:
    base = np.array([0.2, -0.4])
    obj = base + 0.5 * np.array(reach)
    seen_from = camera_direction(side_azimuth(base, obj, base))
    # The arm comes from the base: the camera stands away from it, across and a little past
    # the object, so the gripper is seen in front of its arm.
    assert angle_deg(seen_from, base - obj) == pytest.approx(90.0 + FRONT_DEG, abs=1e-6)


def test_a_two_arm_robot_is_filmed_from_the_side_away_from_its_other_arm() -> None:
    root = np.array([0.0, -0.5])  # the robot's centre, between its arms
    left_base, right_base = np.array([-0.3, -0.5]), np.array([0.3, -0.5])
    for base, outward in ((left_base, -1.0), (right_base, 1.0)):
        obj = base + np.array([0.0, 0.45])
        seen_from = camera_direction(side_azimuth(base, obj, root))
        assert np.sign(seen_from[0]) == outward  # the camera on the arm's outer side
