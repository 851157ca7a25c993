"""Franka Research 3 + Franka Hand: the URDF that `python robots/build_urdfs.py` writes.

Joint origins, axes and limits are the published ones (../shared/reference/robots.md section 2);
the geometry is primitive (harness/robots/generator/shapes.py).
"""

from __future__ import annotations

import numpy as np

from harness.robots.generator.shapes import PI, R_of, Robot, Shape, X, Z, box, capsule

# The older FR3 table (franka_description robots/fr3/joint_limits.yaml, Menagerie franka_fr3):
# it lies inside the current table on every joint, so plans are valid under both.
FR3_LOWER = (-2.7437, -1.7837, -2.9007, -3.0421, -2.8065, 0.5445, -3.0159)
FR3_UPPER = (2.7437, 1.7837, 2.9007, -0.1518, 2.8065, 4.5169, 3.0159)
FR3_VELOCITY = (2.62, 2.62, 2.62, 2.62, 5.26, 4.18, 5.26)
FR3_EFFORT = (87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0)
FR3_ORIGINS = (  # panda/fr3 URDF joint origins (xyz, rpy)
    ((0, 0, 0.333), (0, 0, 0)),
    ((0, 0, 0), (-PI / 2, 0, 0)),
    ((0, -0.316, 0), (PI / 2, 0, 0)),
    ((0.0825, 0, 0), (PI / 2, 0, 0)),
    ((-0.0825, 0.384, 0), (-PI / 2, 0, 0)),
    ((0, 0, 0), (PI / 2, 0, 0)),
    ((0.088, 0, 0), (PI / 2, 0, 0)),
)
FR3_MASSES = (2.397, 2.927, 2.936, 2.245, 2.616, 2.327, 1.817, 0.627)


def build() -> Robot:
    robot = Robot(
        "fr3",
        comment="""
Franka Research 3 with the Franka Hand (primitive geometry, real kinematics).
Joint origins: franka panda/fr3 URDF (identical kinematics). Limits: the older FR3 table
(franka_description joint_limits.yaml, Menagerie fr3), which is contained in the current
frankarobotics table on every joint. Velocities: FR3 dq_max. Masses: FR3 inertials.yaml; hand
0.73 kg and fingers 0.015 kg from the Panda URDF. Collision: franka_arm.xacro capsules
(radii before safety inflation) as cylinder + spheres; hand box; rubber-tip pad boxes.
Root 'base' = the mounting plate (bottom of link0).
""",
    )
    # FR3 link1's and link3's capsules both end inside link2's J2 housing, so they overlap
    # whenever |J2| > ~60 deg (20% of random configurations) while the real links are kept apart
    # by link2: not a self-collision pair.
    robot.artefact_pairs = {frozenset(("left_link1", "left_link3"))}
    p = "left_"
    robot.link("base")
    robot.link(p + "arm_base")
    robot.joint("left_arm_mount", "fixed", "base", p + "arm_base")
    shapes = _link_shapes()
    for i in range(8):
        link = robot.link(f"{p}link{i}", FR3_MASSES[i], "white" if i % 2 else "light")
        link.shapes = shapes[i]
    robot.joint(p + "link0_mount", "fixed", p + "arm_base", p + "link0")
    for i, (xyz, rpy) in enumerate(FR3_ORIGINS):
        robot.joint(
            f"{p}joint{i + 1}",
            "revolute",
            f"{p}link{i}",
            f"{p}link{i + 1}",
            xyz,
            rpy,
            Z,
            FR3_LOWER[i],
            FR3_UPPER[i],
            FR3_EFFORT[i],
            FR3_VELOCITY[i],
        )
    _add_hand(robot, p)
    return robot


def _link_shapes() -> dict[int, list[Shape]]:
    """Collision primitives of link0..link7: franka_arm.xacro capsules (radii before the safety
    inflation) as cylinder + spheres."""
    return {
        0: [
            *capsule((-0.075, 0, 0.06), X, 0.06, 0.03),
            Shape("cylinder", (0.08, 0.03), (0.0, 0.0, 0.015)),
        ],
        # link1: the capsule's lower sphere would reach below the plate; stop the cylinder
        # 5 mm above it instead (link1 moves, the table must not touch it).
        1: [
            *capsule((0, 0, -0.1915 + 0.0025), Z, 0.06, 0.278, ends=(False, True)),
        ],
        2: capsule((0, 0, 0), Z, 0.06, 0.12),
        3: capsule((0, 0, -0.145), Z, 0.06, 0.15),
        4: capsule((0, 0, 0), Z, 0.06, 0.12),
        5: [*capsule((0, 0, -0.26), Z, 0.06, 0.10), *capsule((0, 0.08, -0.13), Z, 0.025, 0.14)],
        6: capsule((0, 0, -0.03), Z, 0.05, 0.08),
        7: [
            *capsule((0, 0, 0.01), Z, 0.04, 0.14),
            *capsule(
                tuple(R_of((0, 0, PI / 4)) @ np.array([0.06, 0, 0.082])),
                tuple(R_of((0, 0, PI / 4)) @ np.array(X)),
                0.03,
                0.01,
            ),
        ],
    }


def _add_hand(robot: Robot, p: str) -> None:
    """Flange (link8), the Franka Hand, its two fingers with the rubber-tip pads, and the TCP."""
    robot.link(p + "link8")
    robot.joint(p + "joint8", "fixed", p + "link7", p + "link8", (0, 0, 0.107))
    hand = robot.link(p + "hand", 0.73, "dark")
    # Hand body between the flange and the finger roots (z 0.0584).
    hand.shapes = [box((0, 0, 0.0302), (0.06, 0.204, 0.0556))]
    robot.joint(p + "hand_joint", "fixed", p + "link8", p + "hand", rpy=(0, 0, -PI / 4))
    for name, sign in (("leftfinger", 1.0), ("rightfinger", -1.0)):
        finger = robot.link(p + name, 0.015, "grey")
        # Finger body (recessed 2 mm behind the pad face) and the rubber tip
        # 17.5 x 15.2 x 18.5 mm at (0, +-7.6 mm, 45.25 mm): its inner face is the finger plane.
        finger.shapes = [
            box((0, sign * 0.009, 0.018), (0.02, 0.014, 0.036)),
            box((0, sign * 0.0076, 0.04525), (0.0175, 0.0152, 0.0185), name=f"{p}{name}_pad"),
        ]
        robot.joint(
            f"{p}finger_joint{1 if sign > 0 else 2}",
            "prismatic",
            p + "hand",
            p + name,
            (0, 0, 0.0584),
            (0, 0, 0),
            (0.0, sign, 0.0),
            0.0,
            0.04,
            100.0,
            0.2,
        )
    robot.link(p + "tcp")
    robot.joint(p + "tcp_joint", "fixed", p + "hand", p + "tcp", (0, 0, 0.1034))
