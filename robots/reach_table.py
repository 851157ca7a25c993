"""The reach table of docs/robots.md: which cells of each arm's object region the arm reaches.

At the robot's nominal placement (middle of its placement range) and home, lift held at its
home: placo IK (harness.planning.ik, arm joints only) puts the TCP 3 cm above the table with the
approach within 40 deg of straight down (tilted away from the arm base by 0, 20 or 40 deg, each
at 8 turns about the approach), within 1 mm / 0.01 rad, on a 5 x 5 grid over the region.

    PYTHONPATH=. python robots/reach_table.py
"""

from __future__ import annotations

import math

import numpy as np

from harness.planning.ik import IKSettings, WholeBodyIK
from harness.robots import RobotModel

ARMS = [
    ("fr3", "left"),
    ("split_aloha", "left"),
    ("split_aloha", "right"),
    ("lift2", "left"),
    ("lift2", "right"),
]
TCP_HEIGHT = 0.03
TILTS_DEG = (0.0, 20.0, 40.0)
TURNS = 8


def rotation_about(axis: np.ndarray, angle: float) -> np.ndarray:
    axis = axis / np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def ee_rotations(approach: np.ndarray, approach_index: int) -> list[np.ndarray]:
    """EE rotations whose column ``approach_index`` is ``approach``, turned about it."""
    ref = np.array([1.0, 0, 0]) if abs(approach[0]) < 0.9 else np.array([0, 1.0, 0])
    b = np.cross(approach, ref)
    b /= np.linalg.norm(b)
    columns = [approach, b, np.cross(approach, b)]
    order = [(i - approach_index) % 3 for i in range(3)]
    R0 = np.stack([columns[k] for k in order], axis=1)
    return [rotation_about(approach, k * 2 * math.pi / TURNS) @ R0 for k in range(TURNS)]


def arm_row(name: str, arm: str) -> str:
    robot = RobotModel.load(name)
    spec = robot.arm(arm)
    active = ([robot.lift_joint] if robot.lift_joint else []) + list(spec.joints)
    ik = WholeBodyIK(robot.urdf_path, active, spec.ee_frame, robot.lift_joint)
    home = robot.home_configuration()
    ik.set_posture(home)
    ik.hold_lift(True)
    q0 = np.array([home[j] for j in active])
    position, yaw = robot.nominal_placement()
    T_root = np.eye(4)
    T_root[:3, :3] = rotation_about(np.array([0, 0, 1.0]), yaw)
    T_root[:3, 3] = position
    ik.set_base_pose(T_root)
    base = ik.fk(q0, spec.base_frame)[:3, 3]
    index = "xyz".index(robot.convention.approach_axis)
    tcp = robot.convention.tcp_offset
    lo, hi = (np.asarray(v, dtype=float) for v in spec.object_region.pos_range)
    settings = IKSettings(position_tolerance=0.001, orientation_tolerance=0.01)
    rng = np.random.default_rng(0)
    reached = 0
    for x in np.linspace(lo[0], hi[0], 5):
        for y in np.linspace(lo[1], hi[1], 5):
            tcp_point = np.array([x, y, TCP_HEIGHT])
            away = np.array([x - base[0], y - base[1], 0.0])
            away /= np.linalg.norm(away)
            reached += any(
                ik.solve(_pose(R, tcp_point - R[:, index] * tcp), q0, rng, settings).success
                for tilt in TILTS_DEG
                for R in ee_rotations(
                    np.array([0, 0, -1.0]) * math.cos(math.radians(tilt))
                    + away * math.sin(math.radians(tilt)),
                    index,
                )
            )
    centre = (lo + hi) / 2
    distance = math.hypot(centre[0] - base[0], centre[1] - base[1])
    return (
        f"| {name} {arm} | ({base[0]:.3f}, {base[1]:.3f}, {base[2]:.3f}) | "
        f"({centre[0]:.2f}, {centre[1]:.2f}) | {distance:.3f} m | {reached}/25 |"
    )


def _pose(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = p
    return T


if __name__ == "__main__":
    for robot_name, arm_name in ARMS:
        print(arm_row(robot_name, arm_name))
