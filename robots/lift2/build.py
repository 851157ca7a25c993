"""ARX Lift-2 (two ARX R5a arms on a lift): the URDF that `python robots/build_urdfs.py` writes.

Joint origins, axes and limits are the published ones (../shared/reference/robots.md section 9);
the geometry is primitive (harness/robots/generator/shapes.py).
"""

from __future__ import annotations

import math

from harness.robots.generator.shapes import PI, Robot, Shape, X, Y, Z, box, cylinder_along, segment

R5A_ORIGINS = (  # R5a.urdf (fiveages-sim/arms_ros2_control); axes z, y, y, y, z, x
    ((0, 0, 0.0565), (0, 0, 0), Z),
    ((0.02, 0, 0.047), (0, 0, 0), Y),
    ((-0.264, 0, 0), (PI, 0, 0), Y),
    ((0.245, -5e-05, -0.06), (0, 0, 0), Y),
    ((0.0702, 5e-05, -0.083391), (0, 0, 0), Z),
    ((0.025286, 0, 0.083391), (PI, 0, 0), X),
)
# Joint ranges of the arms of the Lift-2 URDF (fiveages-sim robot-descriptions-arx
# arx5_description/xacro/lift2.urdf; ../shared/reference/robots.md section 4.2), the robot the
# reference simulates: its lift2.yaml holds the lift at lift_home 0.46, the top of that URDF's
# lift (0-0.46), and its USD (lift2/robot_invisible.usd) carries that description's limits.
# (The R5a.urdf ranges, J4-J6 +-1.57, J3 0-3.14, are narrower; the reference's cuRobo
# r5a_*_arm.yml is not public.)
R5A_LOWER = (-2.094, 0.0, 0.0, -1.671, -1.671, -2.094)
R5A_UPPER = (3.1416, 3.665, 3.24, 1.671, 1.671, 2.094)
R5A_VELOCITY = (4.0, 4.0, 4.5, 4.5, 5.0, 5.0)  # arx5-sdk dq_max
R5A_EFFORT = (30.0, 40.0, 30.0, 15.0, 10.0, 10.0)  # arx5-sdk torque_max
R5A_MASSES = (0.423, 0.097, 1.199, 0.841, 0.124, 0.636, 0.441)
R5A_FINGER_MASS = 0.065
R5A_FINGER_XYZ = (0.08657, 0.0249, -0.00024)
R5A_STROKE = 0.044
R5A_TCP = 0.125  # reference tcp_offset
# Finger collision boxes: MuJoCo Menagerie arx_l5/arx_l5.xml (finger frame = link6 axes):
# half-sizes (0.015, 0.002, 0.018) at x 0.015 and the fingertip pad (0.02, 0.002, 0.00525),
# both at y = -+0.023: inner faces on the closing plane y = -+0.0249. The pad ends at the
# reference's gripper keypoint tool_head, link6 + 0.135 x (InternDataEngine lift2.yaml
# fl/fr_gripper_keypoints), 10 mm past the TCP: centred at 0.135 - 0.08657 - 0.02 = 0.02843
# (Menagerie's own pad, at 0.05, reaches 0.15657, 31.6 mm past the TCP: 2 cm deeper).
R5A_TOOL_HEAD = 0.135
R5A_PAD_X = R5A_TOOL_HEAD - R5A_FINGER_XYZ[0] - 0.02  # pad centre on the finger


def add_r5a(robot: Robot, p: str, parent: str, xyz: tuple[float, float, float]) -> None:
    """One ARX R5a arm with its gripper (approach link6 +x, fingers along link6 +-y)."""
    robot.link(p + "arm_base")
    robot.joint(p + "arm_mount", "fixed", parent, p + "arm_base", xyz)
    base = robot.link(p + "base_link", R5A_MASSES[0], "dark")
    base.shapes = [Shape("cylinder", (0.045, 0.05), (0, 0, 0.025))]
    robot.joint(p + "base_mount", "fixed", p + "arm_base", p + "base_link")
    shapes: dict[int, list[Shape]] = {
        1: [Shape("cylinder", (0.035, 0.03), (0.0, 0, 0.018))],
        2: [
            cylinder_along((0, 0, 0), Y, 0.035, 0.08),
            segment((-0.03, 0, 0), (-0.234, 0, 0), 0.028),
        ],
        3: [
            cylinder_along((0, 0, 0), Y, 0.038, 0.07),
            segment((0.03, 0, -0.004), (0.215, -5e-05, -0.056), 0.025),
        ],
        4: [
            cylinder_along((0, 0, 0), Y, 0.025, 0.06),
            segment((0.02, 0, -0.02), (0.05, 0, -0.045), 0.02),
        ],
        5: [
            Shape("cylinder", (0.032, 0.06), (0, 0, 0)),
            segment((0.01, 0, 0.025), (0.025286, 0, 0.06), 0.025),
        ],
    }
    parent_link = p + "base_link"
    for i, (oxyz, orpy, axis) in enumerate(R5A_ORIGINS):
        n = i + 1
        name = f"{p}link{n}"
        link = robot.link(name, R5A_MASSES[n], "dark" if n % 2 else "light")
        if n < 6:
            link.shapes = shapes[n]
        else:
            # J6 motor and the gripper housing up to the finger rails (x 0.0866).
            link.shapes = [
                cylinder_along((0.002, 0, 0), X, 0.028, 0.02),
                box((0.0445, 0, 0), (0.083, 0.08, 0.05)),
            ]
        robot.joint(
            f"{p}joint{n}",
            "revolute",
            parent_link,
            name,
            oxyz,
            orpy,
            axis,
            R5A_LOWER[i],
            R5A_UPPER[i],
            R5A_EFFORT[i],
            R5A_VELOCITY[i],
        )
        parent_link = name
    fx, fy, fz = R5A_FINGER_XYZ
    for n, sign in ((7, 1.0), (8, -1.0)):
        finger = robot.link(f"{p}link{n}", R5A_FINGER_MASS, "grey")
        # Menagerie arx_l5 finger boxes, the pad ending at tool_head (R5A_PAD_X).
        inner = -sign * 0.023
        finger.shapes = [
            box((0.015, inner, 0.0), (0.03, 0.004, 0.036)),
            box((R5A_PAD_X, inner, 0.0), (0.04, 0.004, 0.0105), name=f"{p}link{n}_pad"),
        ]
        robot.joint(
            f"{p}joint{n}",
            "prismatic",
            p + "link6",
            f"{p}link{n}",
            (fx, sign * fy, fz),
            (0, 0, 0),
            (0.0, sign, 0.0),
            0.0,
            R5A_STROKE,
            20.0,
            0.1,
        )
    robot.link(p + "tcp")
    robot.joint(p + "tcp_joint", "fixed", p + "link6", p + "tcp", (R5A_TCP, 0, 0))


LIFT_XYZ = (0.094118, 0.0010067, 0.27)  # lift joint on the base (lift2.urdf, description 1)
LIFT_RANGE = (0.0, 0.46)
# Arm bases on the carriage. lift2.urdf puts them at carriage + (0.059949, +-0.25, 0.0245),
# i.e. root + (0.154067, 0.25 + 0.0010067, ...). The reference's LeRobot converter
# policy/lmdb2lerobotv21/lmdb2lerobot_lift2_a1.py (lines 382-385) has fl/base_link at robot +
# (0.163030156, 0.248420062, 0.694000185) and fr/base_link at (0.163030139, -0.248420087, ...):
# 9 mm further forward and symmetric about the root. x and y follow the reference. Its z,
# 0.694, is what lift2.urdf gives at a lift of 0.40 (0.27 + 0.40 + 0.0245 = 0.6945), not at
# the lift home 0.46 that the reference holds (robots_lift2.yaml lift_home), so the height
# stays lift2.urdf's.
LIFT_ARM_X = 0.163030 - LIFT_XYZ[0]
LIFT_ARM_Y = 0.24842  # each side of the root's x axis (reference converter)
LIFT_ARM_Z = 0.0245


def build() -> Robot:
    robot = Robot(
        "lift2",
        comment="""
ARX Lift-2: a base with a prismatic lift carrying two ARX R5a arms 0.50 m apart, facing +x.
Base/lift/mounting: fiveages-sim robot-descriptions-arx lift2.urdf (base 21 kg, lift joint at
base + (0.094118, 0.0010067, 0.27), range 0-0.46 m, 0.15 m/s, 400 N; carriage 14.2 kg; arm bases
at root + (0.16303, +-0.24842) as the reference's LeRobot converter has them, 0.0245 above the
carriage as in lift2.urdf). The reference holds the lift at 0.46, the top of this
range. Arms: R5a.urdf chain, lift2.urdf arm joint ranges, arx5-sdk velocity and torque
limits. Gripper: fingers at link6 + (0.08657, +-0.0249, -0.00024) sliding along +-y, 0-0.044
each (0.088 total), Menagerie arx_l5 collision boxes as pads, fingertips at the reference
keypoint tool_head (link6 + 0.135 x). TCP at link6 + 0.125 x (reference tcp_offset).
Root 'base' = the chassis origin on the floor.
""",
    )
    base = robot.link("base", 21.0, "grey")
    lx, ly, lz = LIFT_XYZ
    base.shapes = [
        Shape("cylinder", (0.26, 0.2), (0, 0, 0.16)),  # chassis
        *[
            Shape("sphere", (0.06,), (0.2 * math.cos(a), 0.2 * math.sin(a), 0.06))
            for a in (0.0, 2 * PI / 3, 4 * PI / 3)
        ],  # omni wheels
        box((0.0, 0, 0.805), (0.1, 0.12, 1.09)),  # mast, front face at x 0.05
        box((0.03, 0, 1.38), (0.1, 0.16, 0.06)),  # head
    ]
    carriage = robot.link("lift_link", 14.2, "light")
    carriage.shapes = [
        box((-0.004, 0, -0.05), (0.08, 0.16, 0.15)),  # sleeve on the mast
        box((0.04, 0, 0.0), (0.14, 0.62, 0.049)),  # crossbar, top at the arm bases
    ]
    robot.joint(
        "lift_joint",
        "prismatic",
        "base",
        "lift_link",
        LIFT_XYZ,
        (0, 0, 0),
        Z,
        *LIFT_RANGE,
        400.0,
        0.15,
    )
    add_r5a(robot, "left_", "lift_link", (LIFT_ARM_X, LIFT_ARM_Y - ly, LIFT_ARM_Z))
    add_r5a(robot, "right_", "lift_link", (LIFT_ARM_X, -LIFT_ARM_Y - ly, LIFT_ARM_Z))
    del lx, ly, lz
    return robot
