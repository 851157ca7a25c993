"""Franka Research 3 + Robotiq 2F-85: the URDF that `python robots/build_urdfs.py` writes.

The arm is robots/fr3/build.py's (the same FR3 chain, limits, masses and collision capsules).
The gripper is the Robotiq 2F-85 of MuJoCo Menagerie (google-deepmind/mujoco_menagerie
robotiq_2f85/2f85.xml at 1b428b0, Apache 2.0; read for its numbers, not copied) on the flange
``panda_link8`` (the reference's EE link, franka_robotiq85.yaml ``fl_ee_path``), its fingers
closing along the flange's y (the reference keypoint ``tool_side`` [0, 0.045, 0.155]):

- base: the base mount 7 mm, then the base 3.8 mm above it (Menagerie bodies ``base_mount``,
  ``base``); housing primitives sized to the base up to the knuckle pivots (chosen);
- the four-bar linkage (:func:`pad_centre_and_width`): the spring link turns about (y 0.0132,
  z 0.0609) of the base, the follower sits (0, 0.055, 0.0375) along it and stays parallel, the
  pad (0, -0.0189, 0.01352) on the follower, its two collision boxes 22 x 8 x 18.75 mm stacked
  (inner face 6.6 mm inside the pad frame, 37.5 mm tall). The jaw opens 85.4 mm at the driver's
  0 and closes at 0.8 rad; the pad centre rises 28 mm on the way (0.1415 -> 0.1696 m past the
  flange);
- the harness's gripper is two prismatic pads (docs/extending.md): the pads here are the
  Menagerie pad boxes, fixed at the depth the linkage gives them at a 40 mm jaw
  (``PAD_DEPTH_WIDTH``), sliding along y. The reference's width-dependent extra depth
  (its tcp2base_offset.json, not public) is robot.yaml's ``convention.extra_depth``, derived
  from the same linkage (:func:`extra_depth_table`).
"""

from __future__ import annotations

import math

import numpy as np

from harness.robots.generator.generate import build_module
from harness.robots.generator.shapes import Robot, Shape, Z, box

# Menagerie 2f85.xml (metres).
BASE_Z = 0.007 + 0.0038  # base_mount pos z + base pos z: the base origin above the flange
PIVOT = (0.0132, 0.0609)  # right_spring_link pos (y, z) in the base
LINK = (0.055, 0.0375)  # right_follower pos (y, z) in the spring link
PAD = (-0.0189, 0.01352)  # right_pad pos (y, z) in the follower
PAD_INNER = -0.0026 - 0.004  # pad boxes' inner face (y) in the pad frame
PAD_SIZE = (0.022, 0.008, 0.0375)  # both pad boxes together: x, thickness y, height z
DRIVER_RANGE = (0.0, 0.8)  # driver joint range (rad)
PAD_DEPTH_WIDTH = 0.04  # chosen: the jaw at which the prismatic pads take the linkage's depth
TCP_OFFSET = 0.165  # reference franka_robotiq85.yaml tcp_offset
FINGER_MASS = 0.05  # Menagerie: driver + coupler + spring link + follower + pad, one side
BASE_MASS = 0.777441  # Menagerie base inertial


def pad_centre_and_width(theta: float) -> tuple[float, float]:
    """(pad centre past the flange along z, jaw opening between the pad faces) at the linkage
    angle ``theta`` (rad, 0 open .. 0.8 closed), from Menagerie's 2F-85 bodies."""
    c, s = math.cos(theta), math.sin(theta)
    y = PIVOT[0] + LINK[0] * c - LINK[1] * s
    z = PIVOT[1] + LINK[0] * s + LINK[1] * c
    width = 2.0 * (y + PAD[0] + PAD_INNER)
    centre = BASE_Z + z + PAD[1] + PAD_SIZE[2] / 2.0
    return centre, width


def pad_centre_at(width: float) -> float:
    """The linkage's pad centre (m past the flange) at a jaw opening ``width``."""
    thetas = np.linspace(*DRIVER_RANGE, 801)
    centres, widths = zip(*(pad_centre_and_width(t) for t in thetas), strict=True)
    return float(np.interp(width, widths[::-1], centres[::-1]))


def extra_depth_table(widths: tuple[float, ...]) -> list[float]:
    """The reference-format extra depth at each width: ``tcp_offset - pad centre(width)``, so
    that ``depth + extra - tcp_offset`` puts the pad centres ``depth`` past the grasp point at
    every width, as the linkage closes them there."""
    return [round(TCP_OFFSET - pad_centre_at(w), 5) for w in widths]


def build() -> Robot:
    fr3 = build_module("fr3")
    robot = Robot(
        "franka_robotiq85",
        comment="""
Franka Research 3 with a Robotiq 2F-85 on its flange (primitive geometry, real kinematics).
Arm: robots/fr3/build.py (franka panda/fr3 URDF origins, the older FR3 limit table, FR3
inertials, franka_arm.xacro capsules). Gripper: MuJoCo Menagerie robotiq_2f85 (base 0.0108
above the flange, 0.777 kg; pads 22 x 8 x 37.5 mm), its linkage as two prismatic pads along the
flange y, fixed at the linkage's depth at a 40 mm jaw; TCP at flange + 0.165 z (reference
tcp_offset). Root 'base' = the mounting plate (bottom of link0).
""",
    )
    robot.artefact_pairs = {frozenset(("left_link1", "left_link3"))}
    p = "left_"
    robot.link("base")
    robot.link(p + "arm_base")
    robot.joint("left_arm_mount", "fixed", "base", p + "arm_base")
    shapes = fr3._link_shapes()
    for i in range(8):
        link = robot.link(f"{p}link{i}", fr3.FR3_MASSES[i], "white" if i % 2 else "light")
        link.shapes = shapes[i]
    robot.joint(p + "link0_mount", "fixed", p + "arm_base", p + "link0")
    for i, (xyz, rpy) in enumerate(fr3.FR3_ORIGINS):
        robot.joint(
            f"{p}joint{i + 1}", "revolute", f"{p}link{i}", f"{p}link{i + 1}", xyz, rpy, Z,
            fr3.FR3_LOWER[i], fr3.FR3_UPPER[i], fr3.FR3_EFFORT[i], fr3.FR3_VELOCITY[i],
        )  # fmt: skip
    _add_2f85(robot, p)
    return robot


def _add_2f85(robot: Robot, p: str) -> None:
    """The flange (link8, the EE), the 2F-85 housing, its two pads and the TCP."""
    flange = robot.link(p + "link8", BASE_MASS, "dark")
    pivot_z = BASE_Z + PIVOT[1]
    flange.shapes = [
        Shape("cylinder", (0.0375, BASE_Z), (0.0, 0.0, BASE_Z / 2)),  # base mount
        Shape("cylinder", (0.0375, PIVOT[1]), (0.0, 0.0, BASE_Z + PIVOT[1] / 2)),  # base
        box((0.0, 0.0, pivot_z + 0.005), (0.03, 0.07, 0.01)),  # the knuckle block
    ]
    robot.joint(p + "joint8", "fixed", p + "link7", p + "link8", (0, 0, 0.107))
    centre = pad_centre_at(PAD_DEPTH_WIDTH)
    root_z = pivot_z  # the finger joints at the knuckle pivots' height
    for name, sign in (("right_inner_finger_pad", 1.0), ("left_inner_finger_pad", -1.0)):
        finger = robot.link(p + name, FINGER_MASS, "grey")
        bottom = centre - PAD_SIZE[2] / 2 - root_z
        # The finger (links and follower, 2 mm behind the pad face) from the knuckle to the
        # pad, and the pad, its inner face on the finger plane y = +-opening / 2.
        finger.shapes = [
            box((0, sign * 0.009, bottom / 2), (0.02, 0.014, bottom)),
            box((0, sign * PAD_SIZE[1] / 2, centre - root_z), PAD_SIZE, name=f"{p}{name}_pad"),
        ]
        robot.joint(
            f"{p}{name.split('_')[0]}_finger_joint", "prismatic", p + "link8", p + name,
            (0, 0, root_z), (0, 0, 0), (0.0, sign, 0.0), 0.0, 0.0425, 100.0, 0.2,
        )  # fmt: skip
    robot.link(p + "tcp")
    robot.joint(p + "tcp_joint", "fixed", p + "link8", p + "tcp", (0, 0, TCP_OFFSET))
