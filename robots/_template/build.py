"""TEMPLATE: the URDF of a new robot; copy this folder to robots/<name>/ and edit.

``build()`` returns the robot as primitives (harness/robots/generator/shapes.py): links with a
mass (kg) spread over their shapes by volume, joints with origin (m, rad), axis, limits (rad or
m), effort (N m or N) and velocity (rad/s or m/s). Every number must carry its source in a
comment (URDF / SDK / datasheet / MuJoCo Menagerie, with the file), or say "chosen, no public
source". ``python robots/build_urdfs.py <name>`` writes <name>.urdf and collisions.json.

The numbers below are PLACEHOLDERS of a generic 6-DoF arm (a test builds this template and loads
it with robot.yaml, so the template stays a working robot); replace every one.

Names the pipeline relies on (robot.yaml names them, loading checks them against the URDF):
``<arm>_arm_base`` (massless; x towards the table, z up: the planning and filter frame), the EE
frame named after the reference's EE link, ``<arm>_tcp`` (massless), two prismatic finger joints
whose child links carry a shape named ``<finger link>_pad`` (the contact pads), root ``base``.

Gripper model limits (docs/robots.md, Grippers): two prismatic pads driven by one position servo
(the second finger follows the first by an equality). Linkage grippers (Robotiq 2F-85), suction
and multi-finger hands are not modelled; approximate their pads' travel as two prismatic joints.
"""

from __future__ import annotations

from pathlib import Path

from harness.robots.generator.shapes import PI, Robot, Shape, Y, Z, box, segment

NAME = Path(__file__).resolve().parent.name  # the robot is named like its folder
ORIGINS = (  # placeholder joint origins (xyz, rpy): the published URDF's, to the digit
    ((0.0, 0.0, 0.15), (0.0, 0.0, 0.0)),
    ((0.0, 0.0, 0.05), (-PI / 2, 0.0, 0.0)),
    ((0.0, -0.30, 0.0), (0.0, 0.0, 0.0)),
    ((0.0, -0.25, 0.0), (PI / 2, 0.0, 0.0)),
    ((0.0, 0.0, 0.05), (-PI / 2, 0.0, 0.0)),
    ((0.0, -0.05, 0.0), (PI / 2, 0.0, 0.0)),
)
LOWER = (-3.0, -2.0, -2.5, -3.0, -2.0, -3.0)  # placeholder limits (rad): SDK / URDF
UPPER = (3.0, 2.0, 2.5, 3.0, 2.0, 3.0)
VELOCITY = (3.0,) * 6  # placeholder (rad/s): datasheet
EFFORT = (50.0,) * 6  # placeholder (N m): datasheet
MASSES = (1.0, 1.0, 1.5, 1.0, 0.5, 0.5, 0.3)  # placeholder (kg): base, link1..6 inertials
FINGER_STROKE = 0.04  # placeholder (m per finger): half the jaw opening
FINGER_Z = 0.10  # placeholder (m): finger joint origin along the EE z
TCP = 0.14  # placeholder (m): the reference tcp_offset, or the fingertip centre


def build() -> Robot:
    robot = Robot(NAME, comment="TEMPLATE robot: placeholder numbers (robots/_template/build.py).")
    p = "left_"
    robot.link("base")
    robot.link(p + "arm_base")
    robot.joint(p + "arm_mount", "fixed", "base", p + "arm_base")
    base = robot.link(p + "base_link", MASSES[0], "dark")
    base.shapes = [Shape("cylinder", (0.06, 0.15), (0.0, 0.0, 0.075))]
    robot.joint(p + "base_mount", "fixed", p + "arm_base", p + "base_link")
    parent = p + "base_link"
    for i, (xyz, rpy) in enumerate(ORIGINS):
        link = robot.link(f"{p}link{i + 1}", MASSES[i + 1], "light" if i % 2 else "dark")
        link.shapes = [Shape("cylinder", (0.04, 0.06), (0.0, 0.0, 0.0))]
        if i in (2, 3):  # the upper arm and forearm run along the next joint's origin
            link.shapes.append(
                segment((0.0, -0.04, 0.0), (0.0, ORIGINS[i + 1][0][1] + 0.04, 0.0), 0.03)
            )
        robot.joint(f"{p}joint{i + 1}", "revolute", parent, f"{p}link{i + 1}", xyz, rpy, Z,
                    LOWER[i], UPPER[i], EFFORT[i], VELOCITY[i])  # fmt: skip
        parent = f"{p}link{i + 1}"
    hand = robot.link(p + "hand", 0.4, "dark")
    hand.shapes = [box((0.0, 0.0, 0.04), (0.05, 0.12, 0.06))]
    robot.joint(p + "hand_joint", "fixed", parent, p + "hand", (0.0, 0.0, 0.02))
    for name, sign in (("leftfinger", 1.0), ("rightfinger", -1.0)):
        finger = robot.link(p + name, 0.02, "grey")
        finger.shapes = [box((0.0, sign * 0.005, 0.02), (0.02, 0.01, 0.04), name=f"{p}{name}_pad")]
        robot.joint(f"{p}finger_joint{1 if sign > 0 else 2}", "prismatic", p + "hand", p + name,
                    (0.0, 0.0, FINGER_Z), (0.0, 0.0, 0.0), (0.0, sign * Y[1], 0.0), 0.0,
                    FINGER_STROKE, 50.0, 0.1)  # fmt: skip
    robot.link(p + "tcp")
    robot.joint(p + "tcp_joint", "fixed", p + "hand", p + "tcp", (0.0, 0.0, TCP))
    return robot
