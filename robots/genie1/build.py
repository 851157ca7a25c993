"""AgiBot Genie1 (G1) with 120S parallel grippers: the URDF that `python robots/build_urdfs.py` writes.

Kinematics, masses and the arm collision cylinders: AgiBot's public G1 description in Genie Sim
(github.com/AgibotTech/genie_sim, source/geniesim/app/robot_cfg/G01/G01_omnipicker.urdf at
ebfd1b2, Mozilla Public License 2.0; read for its numbers, not copied): the waist (a prismatic
lift ``idx01_body_joint1`` and a pitch ``idx02_body_joint2``), the head, ``arm_base_link`` and the
two 7-DoF arms ``idx21..27`` / ``idx61..67``. The reference simulates the same arms: its
``genie1.yaml`` home ``[-1.069, 0.608, 0.279, -1.278, 0.727, 1.489, -0.186]`` is Genie Sim's G1
default ``[-1.0751, 0.6109, 0.2793, -1.2846, 0.7295, 1.4957, -0.1868]`` to 7 mrad, and this chain
at the reference's ``body_home [0.32, 0.63]`` puts ``arm_base_link`` at base + (0.3107, 0,
1.2150) pitched 0.63 rad, which is the reference LeRobot converter's ``left_armbase_to_robot_pose``
(policy/lmdb2lerobotv21/lmdb2lerobot_genie1_a1.py 389-393: 0.310688674, 1.21495271, cos 0.808)
to 0.1 mm.

The reference holds the waist and head where its ``genie1.yaml`` puts them (``body_home``,
``head_home``; its cuRobo planners G1_120s_{left,right}_arm_parallel_gripper.yml plan one arm from
``arm_base_link``), so here they are fixed joints at those values.

The 120S gripper has no public description (Genie Sim's URDF carries the Omni-Picker): it is two
prismatic pads sized to the reference's keypoints (genie1.yaml ``tool_tail`` 0.03, ``tool_head``
0.217, ``tool_side`` 0.05 along ``arm_l_end_link`` x) and its 0.1 m ``gripper_max_width``; the
pad and housing sizes are chosen. ``arm_<l|r>_end_link`` (the reference's EE link) is the
``arm_<l|r>_link7`` frame: Genie Sim mounts its gripper base there, approach +z, the fingers
along link7 x for both arms, which is where the reference's R_ee_graspnet puts the closing axis
(EE x = g_y).
"""

from __future__ import annotations

from harness.robots.generator.shapes import PI, R_of, Robot, Shape, Z, box, rpy_of

HALF = PI / 2
# Waist and head as the reference holds them (robots_genie1.yaml body_home, head_home).
BODY_HOME = (0.32, 0.63)
HEAD_HOME = (0.0, 0.349)

# G01_omnipicker.urdf joints (xyz, rpy) per arm, J1..J7; every axis is z.
LEFT_ORIGINS = (
    ((0.0, 0.0, 0.1859), (0.0, 0.0, 0.0)),
    ((0.0, 0.0, 0.0), (-HALF, 0.0, HALF)),
    ((0.0, -0.305, 0.0), (-HALF, HALF, PI)),
    ((0.0, 0.0, 0.0), (-HALF, 0.0, PI)),
    ((0.0, -0.1975, 0.0), (-HALF, 0.0, -PI)),
    ((0.0, 0.0, 0.0), (-HALF, 0.0, 0.0)),
    ((0.0, -0.1805, 0.0), (HALF, 0.0, 0.0)),
)
RIGHT_ORIGINS = (
    ((0.0, 0.0, 0.188), (0.0, 0.0, 0.0)),
    ((0.0, 0.0, 0.0), (-HALF, 0.0, -HALF)),
    ((0.0, -0.305, 0.0), (-HALF, -HALF, PI)),
    *LEFT_ORIGINS[3:],
)
LEFT_LOWER = (-3.14, -2.09, -3.10, -1.48, -3.10, -1.74, -3.10)
LEFT_UPPER = (3.14, 1.48, 3.10, 1.48, 3.10, 1.74, 3.10)
RIGHT_LOWER = (-3.14, -1.48, -3.10, -1.48, -3.10, -1.74, -3.10)
RIGHT_UPPER = (3.14, 2.09, 3.10, 1.48, 3.10, 1.74, 3.10)
EFFORT = (60.0, 60.0, 60.0, 60.0, 30.0, 30.0, 30.0)
VELOCITY = (3.14,) * 7
LEFT_MASSES = (0.4936, 0.46245, 0.50026, 0.27473, 0.25139, 0.26634, 0.06158)
RIGHT_MASSES = (0.4936, 0.41662, 0.49413, 0.27473, 0.25139, 0.26634, 0.06158)
ARM_BASE_MASS = 0.37595
# Arm-link collision cylinders of G01_omnipicker.urdf, (radius, length, xyz, rpy) per link.
LEFT_CYLINDERS = (
    (0.05579, 0.16642, (0.00268, 0.00061, -0.04071), (0.0, 0.0, -1.25664)),
    (0.06302, 0.18086, (0.0, -0.04406, 0.00098), (HALF, 0.0, 0.0)),
    (0.05423, 0.22070, (-0.00275, 0.00064, -0.07224), (PI, 0.0, 2.51327)),
    (0.05789, 0.15496, (0.0, -0.03818, -0.00439), (HALF, 0.0, 0.0)),
    (0.04561, 0.13452, (0.00013, -0.00006, -0.03331), (0.0, 0.0, -0.62832)),
    (0.04851, 0.18166, (0.00025, -0.05548, -0.00194), (0.0, -1.48054, -1.56776)),
    (0.03080, 0.04600, (-0.00005, -0.00230, -0.02250), (PI, 0.0, PI)),
)
RIGHT_CYLINDERS = (
    (0.05484, 0.16643, (0.00019, -0.00200, -0.04071), (-PI, 0.0, 1.25664)),
    (0.06302, 0.18086, (0.0, -0.04406, 0.00098), (HALF, 0.0, 0.0)),
    (0.05216, 0.22061, (0.00066, -0.00002, -0.07219), (0.0, 0.0, 0.0)),
    (0.05789, 0.15496, (0.0, -0.03818, -0.00439), (HALF, 0.0, 0.0)),
    (0.04562, 0.13424, (-0.00022, -0.00004, -0.03345), (0.0, 0.0, 0.0)),
    (0.04857, 0.18272, (-0.00002, -0.05508, -0.00174), (0.0, -1.48351, -1.56897)),
    (0.03080, 0.04600, (-0.00005, -0.00230, -0.02250), (PI, 0.0, PI)),
)

# 120S gripper (chosen geometry, sized to the reference's keypoints; module docstring).
TOOL_TAIL = 0.03  # genie1.yaml tool_tail: the gripper's back, on the end link
TOOL_HEAD = 0.217  # genie1.yaml tool_head = tcp_offset: the fingertips
STROKE = 0.05  # per finger: gripper_max_width 0.1
HOUSING_TOP = 0.15  # chosen: the finger carriages' rails
PAD_HEIGHT = 0.03  # chosen: pad face 30 mm along the approach x 20 mm wide
PAD_WIDTH = 0.02
PAD_THICKNESS = 0.008
FINGER_MASS = 0.05  # chosen
GRIPPER_MASS = 0.6  # chosen
CHEST_ACROSS = 0.20  # chosen: Genie Sim's chest box narrowed to between the shoulders (Genie Sim's Omni-Picker base weighs 0.236 kg)


def build() -> Robot:
    robot = Robot(
        "genie1",
        comment="""
AgiBot Genie1 (G1) with 120S parallel grippers. Waist, head, arm_base_link and both 7-DoF arms:
AgiBot Genie Sim G01_omnipicker.urdf (joint origins, limits, masses, arm collision cylinders;
its commented-out body and head primitives for the torso). Waist and head fixed at the
reference's body_home [0.32, 0.63] and head_home [0, 0.349] (robots_genie1.yaml). Gripper:
no public 120S description; two prismatic pads, 0-0.05 each (0.1 jaw), fingertips at the
reference keypoint tool_head (end link + 0.217 z), housing from tool_tail 0.03; sizes chosen.
Both arms' base frames are the reference's arm_base_link (fl_base_path = fr_base_path).
Root 'base' = base_link, on the floor.
""",
    )
    _add_body(robot)
    for p, side, origins, lower, upper, masses, cylinders, y in (
        ("left_", "l", LEFT_ORIGINS, LEFT_LOWER, LEFT_UPPER, LEFT_MASSES, LEFT_CYLINDERS, 0.025),
        ("right_", "r", RIGHT_ORIGINS, RIGHT_LOWER, RIGHT_UPPER, RIGHT_MASSES, RIGHT_CYLINDERS, -0.025),
    ):  # fmt: skip
        _add_arm(robot, p, side, origins, lower, upper, masses, cylinders, y)
    return robot


def _add_body(robot: Robot) -> None:
    """base_link, the waist (held), the head (held) and arm_base_link."""
    base = robot.link("base", 23.2085, "grey")
    # Genie Sim's (commented-out) base_link boxes: the column and the wheeled foot.
    base.shapes = [
        box((-0.10913, 0.0, 0.51172), (0.29834, 0.33764, 1.0)),
        box((0.0, 0.0, 0.15), (0.59961, 0.449, 0.30273)),
    ]
    waist = robot.link("body_link1", 3.26275, "light")
    # Genie Sim's (commented-out) body_link1 boxes: the two lift carriages.
    waist.shapes = [
        box((0.10278, 0.1, -0.01367), (0.16064, 0.05556, 0.13281)),
        box((0.10181, -0.1, 0.0), (0.16260, 0.04376, 0.16016)),
    ]
    robot.joint(
        "idx01_body_joint1", "fixed", "base", "body_link1", (0.0, 0.0, 0.6485 + BODY_HOME[0])
    )
    torso = robot.link("body_link2", 7.53199, "white")
    # Genie Sim's body_link2 primitives: the waist drum and the chest box (0.181 x 0.346 x
    # 0.3125 m). The chest's 0.3125 m across the shoulders (body_link2 z = arm_base_link y) is
    # narrowed to 0.20 m (chosen): the full box encloses the shoulder housings, where each
    # arm's link2 turns (a contact the real arms do not make).
    torso.shapes = [
        Shape("cylinder", (0.09662, 0.08697), (0.00684, -0.00034, 0.0)),
        Shape("box", (0.18108, 0.34570, CHEST_ACROSS), (0.008, -0.248, 0.0)),
    ]
    waist_rpy = rpy_of(R_of((-HALF, 0.0, 0.0)) @ R_of((0.0, 0.0, BODY_HOME[1])))
    robot.joint(
        "idx02_body_joint2", "fixed", "body_link1", "body_link2", (0.131, 0.0, 0.0), waist_rpy
    )
    robot.link("head_link1")  # the neck (0.414 kg in the URDF, no shape: held with the base)
    head1_rpy = rpy_of(R_of((HALF, 0.0, 0.0)) @ R_of((0.0, 0.0, HEAD_HOME[0])))
    robot.joint(
        "idx11_head_joint1", "fixed", "body_link2", "head_link1", (0.0, -0.441, 0.0), head1_rpy
    )
    head = robot.link("head_link2", 0.70706, "dark")
    head.shapes = [Shape("sphere", (0.11257,), (0.0115, -0.02526, 0.00085))]
    head2_rpy = rpy_of(R_of((-HALF, 0.0, 0.0)) @ R_of((0.0, 0.0, HEAD_HOME[1])))
    robot.joint(
        "idx12_head_joint2",
        "fixed",
        "head_link1",
        "head_link2",
        (0.050238, 0.0, 0.060065),
        head2_rpy,
    )
    robot.link("arm_base_link")
    robot.joint(
        "idx10_arm_base_joint",
        "fixed",
        "body_link2",
        "arm_base_link",
        (0.0, -0.305, 0.0),
        (HALF, 0.0, 0.0),
    )


def _add_arm(
    robot: Robot,
    p: str,
    side: str,
    origins: tuple[tuple[tuple[float, float, float], tuple[float, float, float]], ...],
    lower: tuple[float, ...],
    upper: tuple[float, ...],
    masses: tuple[float, ...],
    cylinders: tuple[
        tuple[float, float, tuple[float, float, float], tuple[float, float, float]], ...
    ],
    y: float,
) -> None:
    """One arm: its base frame (= arm_base_link), the arm mount, seven links, the 120S gripper."""
    robot.link(p + "arm_base")  # the reference's arm_base_link, shared by both arms
    robot.joint(p + "arm_base_frame", "fixed", "arm_base_link", p + "arm_base")
    mount = f"arm_{side}_base_link"
    shoulder = robot.link(mount, ARM_BASE_MASS, "light")
    # Genie Sim's (commented-out) arm base cylinder.
    shoulder.shapes = [Shape("cylinder", (0.0543, 0.09135), (0.0, 0.0, 0.0282))]
    mount_rpy = (-HALF, 0.0, 0.0) if side == "l" else (-HALF, 0.0, PI)
    mount_joint = "idx11_arm_l_base_joint" if side == "l" else "idx12_arm_r_base_joint"
    robot.joint(mount_joint, "fixed", "arm_base_link", mount, (0.0, y, 0.0), mount_rpy)
    first = 21 if side == "l" else 61
    parent = mount
    for i, ((xyz, rpy), mass, (r, length, cxyz, crpy)) in enumerate(
        zip(origins, masses, cylinders, strict=True)
    ):
        name = f"arm_{side}_link{i + 1}"
        link = robot.link(name, mass, "white" if i % 2 == 0 else "light")
        link.shapes = [Shape("cylinder", (r, length), cxyz, crpy)]
        robot.joint(
            f"idx{first + i}_arm_{side}_joint{i + 1}", "revolute", parent, name, xyz, rpy, Z,
            lower[i], upper[i], EFFORT[i], VELOCITY[i],
        )  # fmt: skip
        parent = name
    _add_gripper(robot, p, side, parent)


def _add_gripper(robot: Robot, p: str, side: str, link7: str) -> None:
    """The end link (= link7's frame), the 120S housing, two pads sliding along x, the TCP."""
    end = f"arm_{side}_end_link"
    hand = robot.link(end, GRIPPER_MASS, "dark")
    # Housing from the flange (tool_tail) to the finger rails, and the rails' carriage bar.
    hand.shapes = [
        Shape("cylinder", (0.035, TOOL_TAIL), (0.0, 0.0, TOOL_TAIL / 2)),
        box((0.0, 0.0, (TOOL_TAIL + HOUSING_TOP) / 2), (0.07, 0.06, HOUSING_TOP - TOOL_TAIL)),
        box((0.0, 0.0, HOUSING_TOP - 0.01), (0.14, 0.04, 0.02)),
    ]
    robot.joint(f"idx{51 if side == 'l' else 91}_ee_{side}_joint", "fixed", link7, end)
    pad_z = TOOL_HEAD - PAD_HEIGHT / 2 - HOUSING_TOP  # pad centre above the finger root
    for finger, sign in (("outer", 1.0), ("inner", -1.0)):
        name = f"gripper_{side}_{finger}_link5"
        link = robot.link(name, FINGER_MASS, "grey")
        # Finger body (2 mm behind the pad face) from the rail up to the pad, and the pad, its
        # inner face on the finger plane x = +-opening / 2.
        link.shapes = [
            box((sign * 0.008, 0.0, (pad_z - PAD_HEIGHT / 2) / 2), (0.012, PAD_WIDTH, pad_z - PAD_HEIGHT / 2)),
            box((sign * PAD_THICKNESS / 2, 0.0, pad_z), (PAD_THICKNESS, PAD_WIDTH, PAD_HEIGHT), name=f"{name}_pad"),
        ]  # fmt: skip
        robot.joint(
            f"idx{(41 if finger == 'outer' else 31) + (0 if side == 'l' else 40)}_gripper_{side}_{finger}_joint1",
            "prismatic", end, name, (0.0, 0.0, HOUSING_TOP), (0.0, 0.0, 0.0), (sign, 0.0, 0.0),
            0.0, STROKE, 100.0, 0.2,
        )  # fmt: skip
    robot.link(p + "tcp")
    robot.joint(p + "tcp_joint", "fixed", end, p + "tcp", (0.0, 0.0, TOOL_HEAD))
