"""The small URDF model a robot's ``robots/<name>/build.py`` fills: primitives, links, joints.

Geometry is primitive (cylinders, spheres, boxes sized to the real links; capsules are built as a
cylinder plus two spheres because URDF has no capsule). Shapes are posed in their link frame.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

PI = math.pi
X = (1.0, 0.0, 0.0)
Y = (0.0, 1.0, 0.0)
Z = (0.0, 0.0, 1.0)


@dataclass
class Shape:
    """A primitive posed in the link frame; size: box (x, y, z), cylinder (r, L), sphere (r)."""

    kind: str
    size: tuple[float, ...]
    xyz: tuple[float, ...] = (0.0, 0.0, 0.0)
    rpy: tuple[float, ...] = (0.0, 0.0, 0.0)
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
    artefact_pairs: set[frozenset[str]] = field(default_factory=set)
    """Link pairs left out of the self-collision pairs although they can meet: the primitive
    geometry makes them touch where the real links cannot (say why in the robot's build.py)."""

    def link(self, name: str, mass: float = 0.0, material: str = "grey") -> Link:
        link = Link(name, mass, [], material)
        self.links.append(link)
        return link

    def joint(self, *args: object, **kwargs: object) -> Joint:
        joint = Joint(*args, **kwargs)  # type: ignore[arg-type]
        self.joints.append(joint)
        return joint


def rpy_of(R: np.ndarray) -> tuple[float, float, float]:
    """URDF fixed-axis roll-pitch-yaw of R (R = Rz(y) Ry(p) Rx(r))."""
    with warnings.catch_warnings():  # gimbal lock (pitch +-90 deg) still gives a valid rpy
        warnings.simplefilter("ignore", UserWarning)
        r, p, y = Rotation.from_matrix(R).as_euler("xyz")
    return (float(r), float(p), float(y))


def R_of(rpy: tuple[float, ...]) -> np.ndarray:
    return Rotation.from_euler("xyz", rpy).as_matrix()


def rpy_z_to(direction: np.ndarray) -> tuple[float, float, float]:
    """rpy of a frame whose z axis is ``direction`` (for cylinders along a segment)."""
    d = np.asarray(direction, float)
    d = d / np.linalg.norm(d)
    rot = Rotation.align_vectors([d], [[0.0, 0.0, 1.0]])[0]
    return rpy_of(rot.as_matrix())


def segment(p0: tuple[float, ...], p1: tuple[float, ...], r: float) -> Shape:
    """A cylinder of radius r from p0 to p1."""
    a, b = np.asarray(p0, float), np.asarray(p1, float)
    mid = (a + b) / 2.0
    return Shape("cylinder", (r, float(np.linalg.norm(b - a))), tuple(mid), rpy_z_to(b - a))


def cylinder_along(
    centre: tuple[float, ...] | np.ndarray,
    axis: tuple[float, ...] | np.ndarray,
    r: float,
    length: float,
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
