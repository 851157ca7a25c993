"""Split ALOHA (two AgileX Piper arms on a mobile base): the URDF robots/build_urdfs.py writes.

Joint origins, axes and limits are the published ones (../shared/reference/robots.md sections 9-10);
the geometry is primitive (harness/robots/generator/shapes.py).
"""

from __future__ import annotations

import itertools

from harness.robots.generator.shapes import (
    PI,
    R_of,
    Robot,
    Shape,
    Y,
    Z,
    box,
    cylinder_along,
    rpy_of,
    segment,
)

PIPER_ORIGINS = (  # piper_no_gripper_description.urdf (piper_ros@ac41fcb)
    ((0, 0, 0.123), (0, 0, 0)),
    ((0, 0, 0), (1.5708, -0.1359, -3.1416)),
    ((0.28503, 0, 0), (0, 0, -1.7939)),
    ((-0.021984, -0.25075, 0), (1.5708, 0, 0)),
    ((0, 0, 0), (-1.5708, 0, 0)),
    ((8.8259e-05, -0.091, 0), (1.5708, 0, 0)),
)
# SDK limits; the URDF's J1 upper 2.168 is a typo for 2.618 (robots.md section 9).
PIPER_LOWER = (-2.618, 0.0, -2.967, -1.745, -1.22, -2.0944)
PIPER_UPPER = (2.618, 3.14, 0.0, 1.745, 1.22, 2.0944)
PIPER_VELOCITY = (5.0, 5.0, 5.0, 5.0, 5.0, 3.0)  # URDF placeholders (no datasheet)
PIPER_EFFORT = (100.0,) * 6  # URDF placeholder, also Menagerie's forcerange
PIPER_MASSES = (1.02, 0.71, 1.17, 0.5, 0.38, 0.383)
PIPER_GRIPPER_MASS = 0.15  # link6 with the gripper housing (older chain)
PIPER_FINGER_MASS = 0.0265
# Finger joint origin along link6 z = the fingertip: the reference's gripper keypoint tool_head,
# link6 + 0.12 z (InternDataEngine split_aloha.yaml fl/fr_gripper_keypoints), at its TCP. (The
# older chain's joint7/joint8 and Menagerie's pads put it at 0.13503, 15 mm past the TCP, so
# the reference's grasp poses put those fingers 15 mm deeper than the reference's.)
PIPER_FINGER_Z = 0.12
PIPER_STROKE = 0.05  # per finger: the reference's piper100 jaw 0.10 (the SDK's 0.07 fits in it)
PIPER_TCP = 0.12


def add_piper(robot: Robot, p: str, parent: str, xyz: tuple[float, float, float]) -> None:
    """One Piper arm with its parallel gripper, arm base frame at ``parent`` + xyz (facing +x).

    Gripper frame (robots.md section 10 open point): on the real Piper the jaws travel sideways
    at the zero pose, i.e. along the older-chain link6 x = the newer-chain (SDK, MDH) link6 y.
    The reference's R_ee_graspnet for split_aloha puts the closing axis g_y on EE x, so the
    reference link6 is the older-chain orientation. ``<arm>_link6`` here is therefore the SDK
    link6 turned +90 deg about its z (folded into joint6's origin, so joint values are the real
    ones): approach +z, fingers along +-x. ``<arm>_link6_sdk`` keeps the SDK/newer-URDF frame.
    """
    robot.link(p + "arm_base")
    robot.joint(p + "arm_mount", "fixed", parent, p + "arm_base", xyz)
    base = robot.link(p + "base_link", PIPER_MASSES[0], "dark")
    base.shapes = [Shape("cylinder", (0.055, 0.075), (0, 0, 0.0375))]
    robot.joint(p + "base_mount", "fixed", p + "arm_base", p + "base_link")
    shapes: dict[int, list[Shape]] = {
        1: [Shape("cylinder", (0.05, 0.045), (0, 0, -0.0255))],
        2: [
            Shape("cylinder", (0.045, 0.1), (0, 0, 0)),
            segment((0.03, 0, 0), (0.255, 0, 0), 0.032),
        ],
        3: [
            Shape("cylinder", (0.04, 0.085), (0, 0, 0)),
            segment((0, -0.03, 0), (-0.021984, -0.21, 0), 0.028),
        ],
        4: [Shape("cylinder", (0.03, 0.05), (0, 0, -0.03))],
        5: [
            Shape("cylinder", (0.033, 0.066), (0, 0, 0)),
            segment((0, -0.02, 0), (8.8259e-05, -0.07, 0), 0.03),
        ],
    }
    parent_link = p + "base_link"
    for i, (oxyz, orpy) in enumerate(PIPER_ORIGINS):
        n = i + 1
        name = f"{p}link{n}"
        if n < 6:
            link = robot.link(name, PIPER_MASSES[n], "dark" if n % 2 else "light")
            link.shapes = shapes[n]
            rpy = orpy
        else:
            link = robot.link(name, PIPER_GRIPPER_MASS, "dark")
            link.shapes = [
                Shape("cylinder", (0.03, 0.02), (0, 0, -0.005)),
                box((0, 0, 0.0425), (0.1, 0.05, 0.075)),
            ]
            rpy = rpy_of(R_of(orpy) @ R_of((0, 0, PI / 2)))
        robot.joint(
            f"{p}joint{n}",
            "revolute",
            parent_link,
            name,
            oxyz,
            rpy,
            Z,
            PIPER_LOWER[i],
            PIPER_UPPER[i],
            PIPER_EFFORT[i],
            PIPER_VELOCITY[i],
        )
        parent_link = name
    robot.link(p + "link6_sdk")
    robot.joint(p + "link6_sdk_joint", "fixed", p + "link6", p + "link6_sdk", rpy=(0, 0, -PI / 2))
    _add_piper_gripper(robot, p)


def _add_piper_gripper(robot: Robot, p: str) -> None:
    """The Piper's two prismatic fingers on link6 (Menagerie pads) and the TCP."""
    for n, sign in ((7, 1.0), (8, -1.0)):
        finger = robot.link(f"{p}link{n}", PIPER_FINGER_MASS, "grey")
        # MuJoCo Menagerie agilex_piper/piper.xml (current) finger collision boxes, in this
        # finger frame (opening along sign * x, approach +z): half-sizes (0.0025 closing,
        # 0.012 / 0.015 across, 0.015 along z) at 0.015 and 0.045 below the finger origin,
        # inner faces on the finger plane. Fingertip = the finger origin (PIPER_FINGER_Z).
        finger.shapes = [
            box((sign * 0.0025, 0, -0.045), (0.005, 0.03, 0.03)),
            box((sign * 0.0025, 0, -0.015), (0.005, 0.024, 0.03), name=f"{p}link{n}_pad"),
        ]
        robot.joint(
            f"{p}joint{n}",
            "prismatic",
            p + "link6",
            f"{p}link{n}",
            (0, 0, PIPER_FINGER_Z),
            (0, 0, 0),
            (sign, 0.0, 0.0),
            0.0,
            PIPER_STROKE,
            10.0,
            0.1,
        )
    robot.link(p + "tcp")
    robot.joint(p + "tcp_joint", "fixed", p + "link6", p + "tcp", (0, 0, PIPER_TCP))


# Arm bases w.r.t. the root (the robot prim the reference places and plans from): x and y are
# the reference's own, from its LeRobot converter policy/lmdb2lerobotv21/lmdb2lerobot_split_aloha_a1.py
# (lines 382-385: fl/arm_base at robot + (0.3684792, 0.30600064, 0.65270409), fr/arm_base at
# (0.36847978, -0.30599953, 0.65270409)). The robot frame there is the robot prim whose pose is
# T_world_base (core/robots/template_robot.py line 195: the robot's local pose) and whose origin
# xy the region sampler sets (core/utils/region_sampler.py lines 33-39), so x and y carry over
# as they are. Height: the converter's z is above that prim's origin, whose height above the
# robot's lowest point (which the sampler stands on the floor) is in the robot USD, not public;
# for the Lift-2 the same converter's z is not the simulated arm height either (robots/lift2/
# build.py, LIFT_ARM_Z). So the height stays the Cobot Magic cuRobo fixture's 0.782.
SPLIT_ARM_MOUNT = (0.3684795, 0.306, 0.782)


def build() -> Robot:
    robot = Robot(
        "split_aloha",
        comment="""
Split ALOHA: two AgileX Piper arms side by side facing +x on a mobile base (primitive geometry).
Arm chain: piper_no_gripper_description.urdf (newer chain, piper_ros@ac41fcb), SDK limits; the
URDF's J1 upper limit 2.168 is a typo and is written as 2.618 here. Velocity/effort are the URDF
placeholders. Arm bases at footprint + (0.3685, +-0.306, 0.782): x, y from the reference's
LeRobot converter (lmdb2lerobot_split_aloha_a1.py), height from the Cobot Magic cuRobo fixture
(0.78 m high). Gripper: two prismatic fingers, 0-0.05
each (the reference's piper100 jaw 0.10; the SDK's 0.07 is a robot.yaml variant), Menagerie
agilex_piper collision boxes as pads, fingertips at the reference keypoint tool_head (link6 +
0.12 z). link6 is the SDK link6 turned +90 deg about z (fingers along x);
link6_sdk is the SDK frame. Root 'base' = the footprint on the floor.
""",
    )
    base = robot.link("base", 30.0, "grey")
    ax, ay, az = SPLIT_ARM_MOUNT
    base.shapes = [
        box((-0.05, 0, 0.16), (0.54, 0.48, 0.2)),  # chassis
        *[
            cylinder_along((x, y, 0.06), Y, 0.06, 0.05)
            for x, y in itertools.product((-0.22, 0.12), (-0.2, 0.2))
        ],  # wheels
        box((0.17, 0.2, 0.5), (0.04, 0.04, 0.48)),  # posts
        box((0.17, -0.2, 0.5), (0.04, 0.04, 0.48)),
        # arm crossbar from the posts to the arm bases, its top at the arm bases
        box(((0.11 + ax + 0.06) / 2, 0, az - 0.021), (ax + 0.06 - 0.11, 0.72, 0.042)),
        box((-0.15, 0, 0.75), (0.04, 0.04, 0.98)),  # camera mast
        box((-0.12, 0, 1.26), (0.05, 0.12, 0.04)),  # head camera
    ]
    add_piper(robot, "left_", "base", (ax, ay, az))
    add_piper(robot, "right_", "base", (ax, -ay, az))
    return robot
