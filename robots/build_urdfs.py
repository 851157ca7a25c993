"""Generate robots/<name>/<name>.urdf and collisions.json for fr3, split_aloha and lift2.

The URDFs are the single kinematic description used by placo (IK) and MuJoCo (physics). Joint
origins, axes and limits are the published ones (../shared/reference/robots.md); the geometry is
primitive (cylinders, spheres, boxes sized to the real links; capsules are built as a cylinder
plus two spheres because URDF has no capsule). Each link's mass is the reference mass, spread over
its primitives by volume, so the inertia tensors are physical (positive definite, triangle
inequality holds).

Run ``python robots/build_urdfs.py`` after editing; ``tests/test_robot.py`` checks that the
committed files equal the generator output. ``collisions.json`` (placo's self-collision pairs)
excludes links that cannot move relative to each other, links joined by one joint, the two
fingers of a gripper (they meet by design when closed) and pairs touching at the home pose.
"""

from __future__ import annotations

import itertools
import json
import math
import sys
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

ROBOTS_DIR = Path(__file__).resolve().parent
PI = math.pi

# --------------------------------------------------------------------------------------------
# Small model of a URDF


@dataclass
class Shape:
    """A primitive posed in the link frame; size: box (x, y, z), cylinder (r, L), sphere (r)."""

    kind: str
    size: tuple[float, ...]
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    name: str | None = None  # kept as the URDF collision name (MuJoCo keeps it as the geom name)

    def volume(self) -> float:
        if self.kind == "box":
            return float(np.prod(self.size))
        if self.kind == "cylinder":
            r, length = self.size
            return PI * r * r * length
        (r,) = self.size
        return 4.0 / 3.0 * PI * r**3

    def inertia_unit_mass(self) -> np.ndarray:
        """Inertia of a 1 kg solid about its centre, in the shape frame."""
        if self.kind == "box":
            x, y, z = self.size
            return np.diag([y * y + z * z, x * x + z * z, x * x + y * y]) / 12.0
        if self.kind == "cylinder":
            r, length = self.size
            side = (3 * r * r + length * length) / 12.0
            return np.diag([side, side, r * r / 2.0])
        (r,) = self.size
        return np.eye(3) * 0.4 * r * r


@dataclass
class Link:
    name: str
    mass: float = 0.0
    shapes: list[Shape] = field(default_factory=list)
    material: str = "grey"


@dataclass
class Joint:
    name: str
    kind: str  # fixed, revolute, prismatic
    parent: str
    child: str
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    lower: float = 0.0
    upper: float = 0.0
    effort: float = 0.0
    velocity: float = 0.0


@dataclass
class Robot:
    name: str
    links: list[Link] = field(default_factory=list)
    joints: list[Joint] = field(default_factory=list)
    comment: str = ""

    def link(self, name: str, mass: float = 0.0, material: str = "grey") -> Link:
        link = Link(name, mass, [], material)
        self.links.append(link)
        return link

    def joint(self, *args: object, **kwargs: object) -> Joint:
        joint = Joint(*args, **kwargs)  # type: ignore[arg-type]
        self.joints.append(joint)
        return joint


MATERIALS = {
    "white": (0.92, 0.92, 0.92, 1.0),
    "light": (0.75, 0.76, 0.78, 1.0),
    "grey": (0.45, 0.46, 0.48, 1.0),
    "dark": (0.18, 0.18, 0.2, 1.0),
    "black": (0.05, 0.05, 0.05, 1.0),
    "pad": (0.85, 0.35, 0.1, 1.0),
    "accent": (0.1, 0.35, 0.7, 1.0),
}

# --------------------------------------------------------------------------------------------
# Geometry helpers


def rpy_of(R: np.ndarray) -> tuple[float, float, float]:
    """URDF fixed-axis roll-pitch-yaw of R (R = Rz(y) Ry(p) Rx(r))."""
    with warnings.catch_warnings():  # gimbal lock (pitch +-90 deg) still gives a valid rpy
        warnings.simplefilter("ignore", UserWarning)
        r, p, y = Rotation.from_matrix(R).as_euler("xyz")
    return (float(r), float(p), float(y))


def R_of(rpy: tuple[float, float, float]) -> np.ndarray:
    return Rotation.from_euler("xyz", rpy).as_matrix()


def rpy_z_to(direction: np.ndarray) -> tuple[float, float, float]:
    """rpy of a frame whose z axis is ``direction`` (for cylinders along a segment)."""
    d = np.asarray(direction, float)
    d = d / np.linalg.norm(d)
    rot, _ = Rotation.align_vectors([d], [[0.0, 0.0, 1.0]])
    return rpy_of(rot.as_matrix())


def segment(p0: tuple[float, ...], p1: tuple[float, ...], r: float) -> Shape:
    """A cylinder of radius r from p0 to p1."""
    a, b = np.asarray(p0, float), np.asarray(p1, float)
    mid = (a + b) / 2.0
    return Shape("cylinder", (r, float(np.linalg.norm(b - a))), tuple(mid), rpy_z_to(b - a))


def cylinder_along(
    centre: tuple[float, ...], axis: tuple[float, ...], r: float, length: float
) -> Shape:
    return Shape("cylinder", (r, length), tuple(map(float, centre)), rpy_z_to(np.asarray(axis)))


def capsule(
    centre: tuple[float, ...],
    axis: tuple[float, ...],
    r: float,
    length: float,
    ends: tuple[bool, bool] = (True, True),
) -> list[Shape]:
    """Franka-style capsule (centre, axis, radius, cylinder length) as cylinder + end spheres."""
    c = np.asarray(centre, float)
    u = np.asarray(axis, float) / np.linalg.norm(axis)
    shapes = [cylinder_along(c, u, r, length)]
    for sign, keep in zip((-1.0, 1.0), ends, strict=True):
        if keep:
            shapes.append(Shape("sphere", (r,), tuple(c + sign * u * length / 2.0)))
    return shapes


def box(centre: tuple[float, ...], size: tuple[float, ...], name: str | None = None) -> Shape:
    return Shape("box", tuple(size), tuple(map(float, centre)), name=name)


# --------------------------------------------------------------------------------------------
# Inertia


def inertial_of(link: Link) -> tuple[np.ndarray, np.ndarray]:
    """(COM, inertia about the COM in the link frame): the link mass spread by volume."""
    volumes = np.array([s.volume() for s in link.shapes])
    masses = link.mass * volumes / volumes.sum()
    centres = np.array([s.xyz for s in link.shapes])
    com = (masses[:, None] * centres).sum(0) / link.mass
    inertia = np.zeros((3, 3))
    for shape, m, c in zip(link.shapes, masses, centres, strict=True):
        R = R_of(shape.rpy)
        d = c - com
        inertia += m * (R @ shape.inertia_unit_mass() @ R.T)
        inertia += m * (d @ d * np.eye(3) - np.outer(d, d))
    return com, inertia


# --------------------------------------------------------------------------------------------
# URDF text


def fmt(value: float) -> str:
    text = f"{value:.12g}"
    return "0" if text in ("-0", "0") else text


def vec(values: tuple[float, ...] | np.ndarray) -> str:
    return " ".join(fmt(float(v)) for v in values)


def geometry_xml(shape: Shape) -> str:
    if shape.kind == "box":
        return f'<box size="{vec(shape.size)}"/>'
    if shape.kind == "cylinder":
        r, length = shape.size
        return f'<cylinder radius="{fmt(r)}" length="{fmt(length)}"/>'
    return f'<sphere radius="{fmt(shape.size[0])}"/>'


def link_xml(link: Link) -> list[str]:
    if not link.shapes and link.mass == 0.0:
        return [f'  <link name="{link.name}"/>']
    out = [f'  <link name="{link.name}">']
    if link.mass > 0.0:
        com, I = inertial_of(link)
        out += [
            "    <inertial>",
            f'      <origin xyz="{vec(com)}" rpy="0 0 0"/>',
            f'      <mass value="{fmt(link.mass)}"/>',
            f'      <inertia ixx="{fmt(I[0, 0])}" ixy="{fmt(I[0, 1])}" ixz="{fmt(I[0, 2])}" '
            f'iyy="{fmt(I[1, 1])}" iyz="{fmt(I[1, 2])}" izz="{fmt(I[2, 2])}"/>',
            "    </inertial>",
        ]
    for index, shape in enumerate(link.shapes):
        origin = f'<origin xyz="{vec(shape.xyz)}" rpy="{vec(shape.rpy)}"/>'
        name = shape.name or f"{link.name}_col{index}"
        material = "pad" if shape.name and shape.name.endswith("_pad") else link.material
        out += [
            f'    <visual name="{name}_vis">',
            f"      {origin}",
            f"      <geometry>{geometry_xml(shape)}</geometry>",
            f'      <material name="{material}"/>',
            "    </visual>",
            f'    <collision name="{name}">',
            f"      {origin}",
            f"      <geometry>{geometry_xml(shape)}</geometry>",
            "    </collision>",
        ]
    out.append("  </link>")
    return out


def joint_xml(joint: Joint) -> list[str]:
    out = [
        f'  <joint name="{joint.name}" type="{joint.kind}">',
        f'    <parent link="{joint.parent}"/>',
        f'    <child link="{joint.child}"/>',
        f'    <origin xyz="{vec(joint.xyz)}" rpy="{vec(joint.rpy)}"/>',
    ]
    if joint.kind != "fixed":
        out += [
            f'    <axis xyz="{vec(joint.axis)}"/>',
            f'    <limit lower="{fmt(joint.lower)}" upper="{fmt(joint.upper)}" '
            f'effort="{fmt(joint.effort)}" velocity="{fmt(joint.velocity)}"/>',
        ]
    out.append("  </joint>")
    return out


def urdf_text(robot: Robot) -> str:
    out = [
        '<?xml version="1.0"?>',
        "<!-- Generated by robots/build_urdfs.py; edit the generator, not this file. -->",
    ]
    out += [f"<!-- {line} -->" for line in robot.comment.strip().splitlines()]
    out += [
        f'<robot name="{robot.name}">',
        "  <mujoco>",
        '    <compiler discardvisual="false" fusestatic="false" balanceinertia="true" '
        'strippath="false" angle="radian" autolimits="true"/>',
        "  </mujoco>",
    ]
    for name, rgba in MATERIALS.items():
        out.append(f'  <material name="{name}"><color rgba="{vec(rgba)}"/></material>')
    for link in robot.links:
        out += link_xml(link)
    for joint in robot.joints:
        out += joint_xml(joint)
    out.append("</robot>")
    return "\n".join(out) + "\n"


# --------------------------------------------------------------------------------------------
# Franka FR3 + Franka Hand

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
Z = (0.0, 0.0, 1.0)
X = (1.0, 0.0, 0.0)
Y = (0.0, 1.0, 0.0)


def build_fr3() -> Robot:
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
    p = "left_"
    robot.link("base")
    robot.link(p + "arm_base")
    robot.joint("left_arm_mount", "fixed", "base", p + "arm_base")
    shapes: dict[int, list[Shape]] = {
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
    return robot


# --------------------------------------------------------------------------------------------
# AgileX Piper (newer URDF chain) and the Split ALOHA

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
PIPER_FINGER_Z = 0.13503  # finger joint origin along link6 z (older chain joint7/joint8)
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
    for n, sign in ((7, 1.0), (8, -1.0)):
        finger = robot.link(f"{p}link{n}", PIPER_FINGER_MASS, "grey")
        # MuJoCo Menagerie agilex_piper/piper.xml (current) finger collision boxes, in this
        # finger frame (opening along sign * x, approach +z): half-sizes (0.0025 closing,
        # 0.012 / 0.015 across, 0.015 along z) at 0.015 and 0.045 below the finger origin,
        # inner faces on the finger plane. Fingertip = the finger origin, 0.13503 past link6.
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
# for the Lift-2 the same converter's z is not the simulated arm height either (see LIFT_ARM_Z).
# So the height stays the Cobot Magic cuRobo fixture's 0.782 above the footprint.
SPLIT_ARM_MOUNT = (0.3684795, 0.306, 0.782)


def build_split_aloha() -> Robot:
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
agilex_piper collision boxes as pads. link6 is the SDK link6 turned +90 deg about z (fingers along x);
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


# --------------------------------------------------------------------------------------------
# ARX R5a and the Lift-2

R5A_ORIGINS = (  # R5a.urdf (fiveages-sim/arms_ros2_control); axes z, y, y, y, z, x
    ((0, 0, 0.0565), (0, 0, 0), Z),
    ((0.02, 0, 0.047), (0, 0, 0), Y),
    ((-0.264, 0, 0), (PI, 0, 0), Y),
    ((0.245, -5e-05, -0.06), (0, 0, 0), Y),
    ((0.0702, 5e-05, -0.083391), (0, 0, 0), Z),
    ((0.025286, 0, 0.083391), (PI, 0, 0), X),
)
# R5a URDF ranges; J1 upper 2.168 is a typo for 2.618 (robots.md section 9).
R5A_LOWER = (-2.618, 0.0, 0.0, -1.57, -1.57, -1.57)
R5A_UPPER = (2.618, 3.66, 3.14, 1.57, 1.57, 1.57)
R5A_VELOCITY = (4.0, 4.0, 4.5, 4.5, 5.0, 5.0)  # arx5-sdk dq_max
R5A_EFFORT = (30.0, 40.0, 30.0, 15.0, 10.0, 10.0)  # arx5-sdk torque_max
R5A_MASSES = (0.423, 0.097, 1.199, 0.841, 0.124, 0.636, 0.441)
R5A_FINGER_MASS = 0.065
R5A_FINGER_XYZ = (0.08657, 0.0249, -0.00024)
R5A_STROKE = 0.044
R5A_TCP = 0.125  # reference tcp_offset


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
        # MuJoCo Menagerie arx_l5/arx_l5.xml finger collision boxes (finger frame = link6
        # axes): half-sizes (0.015, 0.002, 0.018) at x 0.015 and the fingertip pad
        # (0.02, 0.002, 0.00525) at x 0.05, both at y = -+0.023: inner faces on the closing
        # plane y = -+0.0249, fingertip 0.08657 + 0.07 = 0.15657 past link6.
        inner = -sign * 0.023
        finger.shapes = [
            box((0.015, inner, 0.0), (0.03, 0.004, 0.036)),
            box((0.05, inner, 0.0), (0.04, 0.004, 0.0105), name=f"{p}link{n}_pad"),
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


def build_lift2() -> Robot:
    robot = Robot(
        "lift2",
        comment="""
ARX Lift-2: a base with a prismatic lift carrying two ARX R5a arms 0.50 m apart, facing +x.
Base/lift/mounting: fiveages-sim robot-descriptions-arx lift2.urdf (base 21 kg, lift joint at
base + (0.094118, 0.0010067, 0.27), range 0-0.46 m, 0.15 m/s, 400 N; carriage 14.2 kg; arm bases
at root + (0.16303, +-0.24842) as the reference's LeRobot converter has them, 0.0245 above the
carriage as in lift2.urdf). The reference holds the lift at 0.46, the top of this
range. Arms: R5a.urdf chain and ranges (J1 upper 2.168 is a typo, written as 2.618), arx5-sdk
velocity and torque limits. Gripper: fingers at link6 + (0.08657, +-0.0249, -0.00024) sliding
along +-y, 0-0.044 each (0.088 total), Menagerie arx_l5 collision boxes as pads. TCP at link6 + 0.125 x (reference tcp_offset).
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


BUILDERS = {"fr3": build_fr3, "split_aloha": build_split_aloha, "lift2": build_lift2}

# --------------------------------------------------------------------------------------------
# Self-collision pairs (placo collisions.json)


def rigid_groups(robot: Robot) -> tuple[dict[str, int], dict[int, int | None]]:
    """Group links connected by fixed joints; map group -> parent group (None for the root)."""
    parent_of = {j.child: j for j in robot.joints}
    group: dict[str, int] = {}
    parent_group: dict[int, int | None] = {}
    for link in robot.links:  # links are listed parents first
        joint = parent_of.get(link.name)
        if joint is None:
            group[link.name] = len(parent_group)
            parent_group[group[link.name]] = None
        elif joint.kind == "fixed":
            group[link.name] = group[joint.parent]
        else:
            group[link.name] = len(parent_group)
            parent_group[group[link.name]] = group[joint.parent]
    return group, parent_group


# Pairs that the primitive geometry makes touch although the real links cannot: FR3 link1's and
# link3's capsules both end inside link2's J2 housing, so they overlap whenever |J2| > ~60 deg
# (20% of random configurations) while the real links are kept apart by link2.
ARTEFACT_PAIRS = {"fr3": {frozenset(("left_link1", "left_link3"))}}


def candidate_pairs(robot: Robot) -> list[tuple[str, str]]:
    """Pairs of links with geometry that can move relative to each other and are not adjacent."""
    group, parent_group = rigid_groups(robot)
    finger_parents = {
        j.child: j.parent for j in robot.joints if j.kind == "prismatic" and j.name != "lift_joint"
    }
    with_geometry = [link.name for link in robot.links if link.shapes]
    pairs = []
    for a, b in itertools.combinations(with_geometry, 2):
        ga, gb = group[a], group[b]
        if ga == gb or parent_group[ga] == gb or parent_group[gb] == ga:
            continue
        if a in finger_parents and b in finger_parents and finger_parents[a] == finger_parents[b]:
            continue  # the two fingers of one gripper meet by design when closed
        if frozenset((a, b)) in ARTEFACT_PAIRS.get(robot.name, set()):
            continue
        pairs.append((a, b))
    return pairs


def home_configuration(name: str) -> dict[str, float]:
    """Home joint values from robots/<name>/robot.yaml (fingers open)."""
    sys.path.insert(0, str(ROBOTS_DIR.parent))
    from harness.robots.model import RobotModel

    return RobotModel.load(name).home_configuration()


def collision_pairs(robot: Robot, urdf: Path) -> list[list[str]]:
    """Candidate pairs minus those touching at home (placo / coal distances)."""
    import tempfile

    import placo

    pairs = candidate_pairs(robot)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "pairs.json"
        path.write_text(json.dumps([list(p) for p in pairs]))
        wrapper = placo.RobotWrapper(str(urdf), placo.Flags.ignore_collisions)
        wrapper.load_collision_pairs(str(path))
    for joint, value in home_configuration(robot.name).items():
        wrapper.set_joint(joint, value)
    wrapper.update_kinematics()
    geometries = wrapper.collision_model.geometryObjects
    frames = wrapper.model.frames

    def link_of(index: int) -> str:
        return frames[geometries[index].parentFrame].name

    touching = set()
    for collision in wrapper.self_collisions(False):
        touching.add(frozenset((link_of(collision.objA), link_of(collision.objB))))
    kept = [list(p) for p in pairs if frozenset(p) not in touching]
    if touching:
        print(f"{robot.name}: excluded pairs touching at home: {sorted(map(sorted, touching))}")
    return kept


def main() -> None:
    for name, builder in BUILDERS.items():
        robot = builder()
        folder = ROBOTS_DIR / name
        folder.mkdir(exist_ok=True)
        urdf = folder / f"{name}.urdf"
        urdf.write_text(urdf_text(robot))
        print(f"{name}: {len(robot.links)} links, {len(robot.joints)} joints")
        if "--no-collisions" in sys.argv:
            continue
        pairs = collision_pairs(robot, urdf)
        (folder / "collisions.json").write_text(json.dumps(pairs, indent=1) + "\n")
        print(f"{name}: {len(pairs)} self-collision pairs")


if __name__ == "__main__":
    main()
