"""The planning world per semantics (``Semantics.planning_world``, the one place of the rule).

``reference`` builds it as the reference controllers do: the table and every object whose name
contains a default ignore substring (``material``, ``Plane``, ``conveyor``, ``scene``,
``table``) or one of the pick's ``ignore_substring`` are absent, whatever
``physics.table_contact`` says. ``strict`` plans around everything physical. The physics
collision groups keep following ``physics.table_contact``.
"""

from __future__ import annotations

import numpy as np
import pytest
from helpers import make_task, scene_planner, top_down_grasp, write_box

from harness.config import PickConfig
from harness.pick.semantics import REFERENCE_IGNORE_SUBSTRINGS, STRICT_TABLE_CLEARANCE, Semantics
from harness.planning.planner import PickPlanner
from harness.planning.world import ATTACH_OFFSET
from harness.sim import Scene
from harness.sim.masks import TABLE_BIT


def test_reference_defaults_are_the_controllers_list() -> None:
    """The list the reference workflow passes (docs/reference-pick-skill.md section 8)."""
    assert REFERENCE_IGNORE_SUBSTRINGS == ("material", "Plane", "conveyor", "scene", "table")


def test_reference_leaves_the_table_out() -> None:
    """Under reference the table is absent from planning; the rule takes no physics setting,
    so this holds with robot-table contact on (the checker test below shows it on a scene)."""
    world = Semantics.from_pick(PickConfig()).planning_world("cube")
    assert not world.check_table and world.table_clearance == 0.0
    assert world.ignore_substring == REFERENCE_IGNORE_SUBSTRINGS
    # the target is out of the world for the grasp and attached to the hand for the carry;
    # only the planned arm counts (pick.py update_specific / attach_obj, the robot ignored)
    assert world.target == "cube" and not world.check_target and world.attach_target
    assert not world.whole_robot and world.rule == "reference"


def test_reference_adds_the_picks_ignore_substring_to_the_defaults() -> None:
    world = Semantics.from_pick(PickConfig(ignore_substring=["gso_box", "table"])).planning_world(
        "cube"
    )
    assert world.ignore_substring == (*REFERENCE_IGNORE_SUBSTRINGS, "gso_box")


def test_strict_plans_around_the_table_and_every_object() -> None:
    pick = PickConfig(semantics="strict", ignore_substring=["gso_box"])
    world = Semantics.from_pick(pick).planning_world("cube")
    assert world.check_table and world.table_clearance == STRICT_TABLE_CLEARANCE
    assert world.ignore_substring == ()
    assert world.check_target and not world.attach_target and world.whole_robot
    assert world.rule == "strict"


def test_robot_ignore_substring_replaces_the_default_list() -> None:
    """A robot-level ignore_substring replaces the controllers' default (template_controller.py
    __init__); the pick's own list adds to it. A list without "table" keeps the table in."""
    pick = PickConfig(robot_ignore_substring=["material"], ignore_substring=["gso_box"])
    world = Semantics.from_pick(pick).planning_world("cube")
    assert world.ignore_substring == ("material", "gso_box")
    assert world.check_table and world.table_clearance == 0.0
    with_table = PickConfig(robot_ignore_substring=["material", "table"])
    assert not Semantics.from_pick(with_table).planning_world("cube").check_table


# --------------------------------------------------------------------------------------------
# The rule applied by the collision checker on a scene with a physical table


@pytest.fixture(scope="module")
def physical_table(tmp_path_factory: pytest.TempPathFactory) -> tuple[Scene, PickPlanner, dict]:
    """FR3 with robot-table contact on, the target, a ``scene_box`` and a ``gso_box``; joint
    poses that put the hand 3 cm into the table and the palm into each box."""
    mesh = write_box(tmp_path_factory.mktemp("world_cube"), (0.04, 0.04, 0.04), "cube")

    def at(x: float, y: float) -> dict:
        return {"placement": {"pos_range": [[x, y, 0.0], [x, y, 0.0]], "yaw_range": [0, 0]}}

    task = make_task(
        "fr3",
        "left",
        mesh,
        object=at(-0.1, 0.0),
        extra_objects=[
            {"name": "scene_box", "mesh": str(mesh), **at(0.15, 0.0)},
            {"name": "gso_box", "mesh": str(mesh), **at(0.0, 0.15)},
        ],
        physics={"table_contact": True},
    )
    scene, planner = scene_planner(task)
    strict = Semantics.from_pick(PickConfig(semantics="strict"))
    planner.sync(strict.planning_world("target"))
    q_home = scene.active_q("left")
    poses = {}
    for name in ("scene_box", "gso_box"):
        T = top_down_grasp(scene, "left", name)
        T[:3, 3] += [0.0, 0.0, -0.03]  # the palm into the box
        poses[name] = T
    T = top_down_grasp(scene, "left")
    T[:3, 3] += [0.15, -0.15, -0.07]  # away from every object, TCP 3 cm below the table top
    poses["table"] = T
    q = {}
    for name, T in poses.items():
        result = planner.ik.solve(T, q_home, np.random.default_rng(0))
        assert result.success, name
        q[name] = result.q
    return scene, planner, q


def test_physics_keeps_robot_table_contact(physical_table) -> None:
    """Physics follows ``physics.table_contact`` exactly: the robot's geoms collide with the
    table in the simulation even though reference planning leaves the table out."""
    scene = physical_table[0]
    robot_geoms = np.flatnonzero(scene.robot_geom & (scene.model.geom_contype > 0))
    assert all(scene.model.geom_conaffinity[g] & TABLE_BIT for g in robot_geoms)


def test_checker_reference_ignores_table_and_scene_names_strict_avoids_them(
    physical_table,
) -> None:
    _scene, planner, q = physical_table
    reference = Semantics.from_pick(PickConfig()).planning_world("target")
    own = Semantics.from_pick(PickConfig(ignore_substring=["gso_box"])).planning_world("target")
    strict = Semantics.from_pick(PickConfig(semantics="strict")).planning_world("target")
    planner.sync(reference)
    assert not planner.checker.collides(q["table"], "transport")
    assert not planner.checker.collides(q["scene_box"], "transport")
    assert planner.checker.collides(q["gso_box"], "transport")  # not on the default list
    planner.sync(own)
    assert not planner.checker.collides(q["gso_box"], "transport")
    planner.sync(strict)
    for name in ("table", "scene_box", "gso_box"):
        assert planner.checker.collides(q[name], "transport"), name


def test_checker_robot_ignore_substring_replaces_the_defaults(physical_table) -> None:
    """On the scene: the robot's list ["material"] replaces the defaults, so the table and the
    ``scene_box`` (on the default list, not on the robot's) are obstacles again."""
    _scene, planner, q = physical_table
    replaced = Semantics.from_pick(PickConfig(robot_ignore_substring=["material"]))
    planner.sync(replaced.planning_world("target"))
    assert planner.checker.collides(q["table"], "transport")
    assert planner.checker.collides(q["scene_box"], "transport")
    planner.sync(Semantics.from_pick(PickConfig()).planning_world("target"))
    assert not planner.checker.collides(q["table"], "transport")
    assert not planner.checker.collides(q["scene_box"], "transport")


def test_checker_target_out_for_the_grasp_and_attached_for_the_carry(physical_table) -> None:
    """Reference: a palm pushed 3 cm into the target is no collision (the target is out of the
    world, pick.py update_specific); strict: it is. After ``attach`` at the grasp, the target
    rides in the hand 1 cm up (attach_obj): holding it where the gso_box stands is a carry
    collision of the target with the box; detached, the same pose is free."""
    scene, planner, _q = physical_table
    rng = np.random.default_rng(0)
    q_home = scene.active_q("left")
    T_grasp = top_down_grasp(scene, "left")
    q_grasp = planner.ik.solve(T_grasp, q_home, rng).q
    T_press = T_grasp.copy()
    T_press[:3, 3] += [0.0, 0.0, -0.03]
    q_press = planner.ik.solve(T_press, q_home, rng).q
    q_over_box = planner.ik.solve(top_down_grasp(scene, "left", "gso_box"), q_home, rng).q
    reference = Semantics.from_pick(PickConfig()).planning_world("target")
    strict = Semantics.from_pick(PickConfig(semantics="strict")).planning_world("target")
    planner.sync(strict)
    assert planner.checker.collides(q_press, "approach")
    planner.sync(reference)
    checker = planner.checker
    assert not checker.collides(q_press, "approach")
    assert not checker.collides(q_over_box, "transport")
    target = scene.objects["target"]
    z_lying = float(scene.data.qpos[target.qpos_adr + 2])
    checker.attach(q_grasp)
    assert not checker.collides(q_grasp, "carry")
    z_held = float(checker.data.qpos[target.qpos_adr + 2])
    assert z_held - z_lying == pytest.approx(ATTACH_OFFSET, abs=2e-4)
    pairs = checker.contacts(q_over_box, "carry")
    geom_object = scene.geom_object
    names = scene.object_names
    hit = {tuple(sorted(names[geom_object[g]] for g in pair)) for pair in pairs}
    assert ("gso_box", "target") in hit, checker.describe(pairs)
    checker.detach()
    assert not checker.collides(q_over_box, "carry")
