"""URDF facts: the links and joints (type, limits) of a robot's URDF, read with ElementTree.

Only what robot.yaml validation and the harness need; the full kinematics and geometry are read
by MuJoCo and placo from the same file.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from harness.config import ConfigError


@dataclass(frozen=True)
class UrdfJoint:
    """A URDF joint as far as validation and the harness need it."""

    name: str
    kind: str
    parent: str
    child: str
    lower: float
    upper: float
    velocity: float
    effort: float


@dataclass(frozen=True)
class UrdfInfo:
    robot_name: str
    links: tuple[str, ...]
    joints: dict[str, UrdfJoint]
    root: str


def read_urdf(path: Path) -> UrdfInfo:
    """Parse link names and joints (type, limits) from a URDF; errors name the file."""
    try:
        root = ET.parse(path).getroot()
    except FileNotFoundError:
        raise ConfigError("URDF file not found", file=path) from None
    except (ET.ParseError, OSError) as exc:
        raise ConfigError(f"cannot read URDF: {exc}", file=path) from None
    links = tuple(link.get("name", "") for link in root.findall("link"))
    joints: dict[str, UrdfJoint] = {}
    for element in root.findall("joint"):
        limit = element.find("limit")
        attr = limit.attrib if limit is not None else {}
        name = element.get("name", "")
        parent = element.find("parent")
        child = element.find("child")
        joints[name] = UrdfJoint(
            name=name,
            kind=element.get("type", ""),
            parent=parent.get("link", "") if parent is not None else "",
            child=child.get("link", "") if child is not None else "",
            lower=float(attr.get("lower", "nan")),
            upper=float(attr.get("upper", "nan")),
            velocity=float(attr.get("velocity", "inf")),
            effort=float(attr.get("effort", "inf")),
        )
    children = {j.child for j in joints.values()}
    roots = [link for link in links if link not in children]
    if len(roots) != 1:
        raise ConfigError(f"URDF must have exactly one root link, found {roots}", file=path)
    return UrdfInfo(root.get("name", ""), links, joints, roots[0])
