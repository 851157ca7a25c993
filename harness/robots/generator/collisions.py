"""Self-collision pairs of a generated robot (placo's ``collisions.json``).

Excluded: links that cannot move relative to each other, links joined by one joint, the two
fingers of a gripper (prismatic joints sharing a parent: they meet by design when closed), the
robot's declared ``artefact_pairs`` and pairs touching at the home pose of its robot.yaml.
"""

from __future__ import annotations

import itertools
import json
from pathlib import Path

from harness.robots.generator.shapes import Robot


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


def candidate_pairs(robot: Robot) -> list[tuple[str, str]]:
    """Pairs of links with geometry that can move relative to each other and are not adjacent."""
    group, parent_group = rigid_groups(robot)
    finger_parents = {j.child: j.parent for j in robot.joints if j.kind == "prismatic"}
    with_geometry = [link.name for link in robot.links if link.shapes]
    pairs = []
    for a, b in itertools.combinations(with_geometry, 2):
        ga, gb = group[a], group[b]
        if ga == gb or parent_group[ga] == gb or parent_group[gb] == ga:
            continue
        if a in finger_parents and b in finger_parents and finger_parents[a] == finger_parents[b]:
            continue  # the two fingers of one gripper meet by design when closed
        if frozenset((a, b)) in robot.artefact_pairs:
            continue
        pairs.append((a, b))
    return pairs


def home_configuration(name: str) -> dict[str, float]:
    """Home joint values from robots/<name>/robot.yaml (fingers open)."""
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
