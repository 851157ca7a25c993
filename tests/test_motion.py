"""Motion planning: collision classes per phase, RRT-Connect, shortcutting, Cartesian paths,
the chained plan and the ik feasibility test."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
from helpers import make_task, scene_planner, top_down_grasp, write_box

from harness.planning.collision import CollisionChecker
from harness.planning.paths import interpolate_pose, rrt_connect, shortcut
from harness.planning.world import PlanningWorld
from harness.sim import Scene
from harness.transforms import invert_T

# --------------------------------------------------------------------------------------------
# Pure functions


def test_interpolate_pose_endpoints_and_midpoint() -> None:
    A = np.eye(4)
    B = np.eye(4)
    B[:3, 3] = [0.2, 0.0, 0.0]
    angle = np.pi / 2
    B[:3, :3] = [[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]]
    assert np.allclose(interpolate_pose(A, B, 0.0), A)
    assert np.allclose(interpolate_pose(A, B, 1.0), B)
    mid = interpolate_pose(A, B, 0.5)
    assert np.allclose(mid[:3, 3], [0.1, 0.0, 0.0])
    half = np.pi / 4
    assert np.allclose(mid[:2, 0], [np.cos(half), np.sin(half)])


def _walls_2d():
    """A 2-D world [0, 1]^2 with a wall x in [0.45, 0.55] except a gap y in [0.85, 0.95]."""

    def free(q: np.ndarray) -> bool:
        return not (0.45 <= q[0] <= 0.55 and not 0.85 <= q[1] <= 0.95)

    def edge(a: np.ndarray, b: np.ndarray) -> bool:
        n = int(np.ceil(np.max(np.abs(b - a)) / 0.005)) + 1
        return all(free(a + (b - a) * t) for t in np.linspace(0.0, 1.0, n))

    return free, edge


def test_rrt_connect_finds_a_collision_free_path_through_a_gap() -> None:
    free, edge = _walls_2d()
    start, goal = np.array([0.1, 0.1]), np.array([0.9, 0.1])
    assert not edge(start, goal)
    path = rrt_connect(
        start, goal, np.zeros(2), np.ones(2), free, edge, np.random.default_rng(0), 0.1, 5000, 5000
    )
    assert path is not None
    assert np.allclose(path[0], start) and np.allclose(path[-1], goal)
    assert all(edge(a, b) for a, b in itertools.pairwise(path))
    short = shortcut(path, edge, np.random.default_rng(0), 100)
    assert len(short) <= len(path)
    assert all(edge(a, b) for a, b in itertools.pairwise(short))
    assert np.allclose(short[0], start) and np.allclose(short[-1], goal)


def test_rrt_connect_gives_up_within_its_budget() -> None:
    """A goal walled in completely: None after exactly the sample budget, the same every run."""
    samples = []

    def free(q: np.ndarray) -> bool:
        samples.append(q)
        return not 0.45 <= q[0] <= 0.55

    def edge(a: np.ndarray, b: np.ndarray) -> bool:
        return all(not 0.45 <= (a + (b - a) * t)[0] <= 0.55 for t in np.linspace(0.0, 1.0, 50))

    def attempt() -> list[np.ndarray] | None:
        samples.clear()
        return rrt_connect(
            np.array([0.1, 0.5]), np.array([0.9, 0.5]), np.zeros(2), np.ones(2), free, edge,
            np.random.default_rng(0), 0.1, 300, 10**6,
        )  # fmt: skip

    assert attempt() is None
    first = [q.copy() for q in samples]
    # Each of the 300 iterations extends one tree once and may connect the other several times.
    assert 300 <= len(first) < 300 * 20
    assert attempt() is None
    assert len(samples) == len(first)
    assert all(np.array_equal(a, b) for a, b in zip(samples, first, strict=True))


# --------------------------------------------------------------------------------------------
# Collision classes


@pytest.fixture(scope="module")
def fr3(tmp_path_factory: pytest.TempPathFactory):
    mesh = write_box(tmp_path_factory.mktemp("motion_cube"), (0.04, 0.04, 0.04), "cube")
    task = make_task(
        "fr3",
        "left",
        mesh,
        object={
            "placement": {"pos_range": [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]], "yaw_range": [0, 0]}
        },
    )
    scene, planner = scene_planner(task)
    return task, scene, planner


def test_checker_phases(fr3) -> None:
    """Home is free; the hand at the grasp touches the cube with its fingers only, which the
    approach allows and the transport does not; carrying ignores the held object."""
    _task, scene, planner = fr3
    planner.sync(PlanningWorld("target", check_table=True))
    checker = planner.checker
    q_home = scene.active_q("left")
    assert checker.contacts(q_home, "transport") == []
    # Lower the TCP 1 cm below the cube centre: the open fingers straddle it, the pads touch
    # nothing, so take a pose that puts a finger into the cube: shift 2 cm sideways.
    T = top_down_grasp(scene, "left")
    T[:3, 3] += [0.0, 0.0, -0.01]
    T[:3, 3] += T[:3, 1] * 0.035  # finger axis: y of the hand
    result = planner.ik.solve(T, q_home, np.random.default_rng(0))
    assert result.success
    transport = checker.contacts(result.q, "transport")
    assert transport, "a finger inside the cube is a collision while transporting"
    assert checker.contacts(result.q, "approach") == []
    assert checker.contacts(result.q, "carry") == []


def test_checker_table_switch(fr3) -> None:
    """A hand 3 cm into the table: a collision only when the planning world holds the table."""
    _task, scene, planner = fr3
    q_home = scene.active_q("left")
    T = top_down_grasp(scene, "left")
    T[:3, 3] += [0.15, 0.0, -0.07]  # beside the cube, TCP 3 cm below the table top
    result = planner.ik.solve(T, q_home, np.random.default_rng(0))
    assert result.success
    planner.sync(PlanningWorld("target", check_table=True))
    assert planner.checker.collides(result.q, "transport")
    planner.sync(PlanningWorld("target", check_table=False))
    assert not planner.checker.collides(result.q, "transport")
    planner.sync(PlanningWorld("target", check_table=True))


def test_checker_ignore_substring(tmp_path: Path) -> None:
    """The pick's ignore_substring (the reference planner's ignore list) leaves the objects it
    names out of the planning world; the target object follows check_target alone."""
    mesh = write_box(tmp_path, (0.04, 0.04, 0.04), "cube")
    fixed = {"yaw_range": [0, 0]}
    task = make_task(
        "fr3",
        "left",
        mesh,
        object={"placement": {"pos_range": [[-0.1, 0.0, 0.0], [-0.1, 0.0, 0.0]], **fixed}},
        extra_objects=[
            {
                "name": "gso_box_left",
                "mesh": str(mesh),
                "placement": {"pos_range": [[0.15, 0.0, 0.0], [0.15, 0.0, 0.0]], **fixed},
            }
        ],
    )
    scene, planner = scene_planner(task)
    planner.sync(PlanningWorld("target", check_table=False))  # also the IK's base pose and posture
    q_home = scene.active_q("left")
    hits = {}
    for name in ("gso_box_left", "target"):
        T = top_down_grasp(scene, "left", name)
        T[:3, 3] += [0.0, 0.0, -0.03]  # the palm into the box
        result = planner.ik.solve(T, q_home, np.random.default_rng(0))
        assert result.success
        hits[name] = result.q
    planner.sync(PlanningWorld("target", check_table=False))
    assert planner.checker.collides(hits["gso_box_left"], "transport")
    planner.sync(
        PlanningWorld("target", check_table=False, ignore_substring=("material", "gso_box"))
    )
    assert not planner.checker.collides(hits["gso_box_left"], "transport")
    assert planner.checker.collides(hits["target"], "transport")
    planner.sync(PlanningWorld("target", check_table=False, ignore_substring=("target",)))
    assert planner.checker.collides(hits["target"], "transport")


def test_self_contacts_of_the_physics_model_are_collisions(fr3) -> None:
    """Any robot-robot contact MuJoCo generates (not parent-child, not welded) is a collision,
    e.g. link1 against link3 when the elbow folds back, which would stop the arm in simulation.
    """
    _task, scene, planner = fr3
    planner.sync(PlanningWorld("target", check_table=False))
    rng = np.random.default_rng(0)
    checker = planner.checker
    found = None
    for _ in range(3000):
        q = rng.uniform(planner.lower, planner.upper)
        pairs = checker.contacts(q, "transport")
        robot_pairs = [p for p in pairs if scene.robot_geom[p[0]] and scene.robot_geom[p[1]]]
        if robot_pairs:
            found = robot_pairs[0]
            break
    assert found is not None, "no self-collision found in 3000 random configurations"
    m = scene.model
    body_a, body_b = (int(m.geom_bodyid[g]) for g in found)
    assert body_a != body_b
    assert m.body_parentid[body_a] != body_b and m.body_parentid[body_b] != body_a


def test_arm_vs_arm_is_a_collision(tmp_path: Path) -> None:
    """Split ALOHA: the left arm swung into the right arm collides."""
    mesh = write_box(tmp_path, (0.04, 0.04, 0.04), "cube")
    task = make_task("split_aloha", "left", mesh)
    scene = Scene.build(task.robot, task.objects, task.physics)
    scene.reset(task, np.random.default_rng(0))
    checker = CollisionChecker(scene, "left")
    checker.sync(PlanningWorld("target", check_table=False))
    q = scene.active_q("left")
    assert not checker.collides(q, "transport")
    rng = np.random.default_rng(1)
    lower = np.array([scene.robot.joint_limits(j)[0] for j in scene.arms["left"].active_names])
    upper = np.array([scene.robot.joint_limits(j)[1] for j in scene.arms["left"].active_names])
    cross = 0
    for _ in range(4000):
        sample = rng.uniform(lower, upper)
        for a, b in checker.contacts(sample, "transport"):
            arm_a, arm_b = scene.geom_arm[a], scene.geom_arm[b]
            cross += arm_a >= 0 and arm_b >= 0 and arm_a != arm_b
        if cross:
            break
    assert cross, "no left-right arm contact found while sweeping the left arm"


# --------------------------------------------------------------------------------------------
# Plans


def test_chain_plan_is_straight_where_it_must_be(fr3) -> None:
    """Forward plan of a top-down grasp: transport from the current state, a straight
    approach, a vertical lift; every waypoint collision-free for its phase."""
    _task, scene, planner = fr3
    planner.sync(PlanningWorld("target", check_table=True))
    q_now = scene.active_q("left")
    T_grasp = top_down_grasp(scene, "left")
    T_pre = T_grasp.copy()
    T_pre[:3, 3] += [0.0, 0.0, 0.05]
    T_lift = T_grasp.copy()
    T_lift[:3, 3] += [0.0, 0.0, 0.1]
    verdict = planner.plan_chain(
        0, 0, 0.1, q_now, T_pre, T_grasp, T_lift, False, np.random.default_rng(0)
    )
    assert verdict.feasible, verdict.detail
    plan = verdict.plan
    assert np.allclose(plan.transport[0], q_now)
    for waypoints, T_from, T_to in ((plan.approach, T_pre, T_grasp), (plan.lift, T_grasp, T_lift)):
        points = np.array([planner.ik.fk(q)[:3, 3] for q in waypoints])
        direction = (T_to[:3, 3] - T_from[:3, 3]) / np.linalg.norm(T_to[:3, 3] - T_from[:3, 3])
        offsets = points - points[0]
        lateral = offsets - np.outer(offsets @ direction, direction)
        assert np.max(np.linalg.norm(lateral, axis=1)) < 1e-3
        assert np.linalg.norm(points[-1] - T_to[:3, 3]) < 1e-3
    checker = planner.checker
    assert not any(checker.collides(q, "transport") for q in plan.transport)
    assert not any(checker.collides(q, "approach") for q in plan.approach)


def test_rrt_is_used_when_the_direct_path_collides(tmp_path: Path) -> None:
    """A wall (a tall box) between the hand and the target: the direct joint line collides,
    RRT-Connect goes around it, and the path is collision-free."""
    cube = write_box(tmp_path / "cube", (0.04, 0.04, 0.04), "cube")
    wall = write_box(tmp_path / "wall", (0.02, 0.5, 0.3), "wall")
    fixed = {"yaw_range": [0, 0]}
    task = make_task(
        "fr3",
        "left",
        cube,
        object={"placement": {"pos_range": [[0.35, 0.0, 0.0], [0.35, 0.0, 0.0]], **fixed}},
        extra_objects=[
            {
                "name": "wall",
                "mesh": str(wall),
                "mass": 50.0,
                "placement": {"pos_range": [[0.15, 0.0, 0.0], [0.15, 0.0, 0.0]], **fixed},
            }
        ],
    )
    scene, planner = scene_planner(task)
    planner.sync(PlanningWorld("target", check_table=True))
    q_now = scene.active_q("left")
    T_grasp = top_down_grasp(scene, "left")
    T_pre = T_grasp.copy()
    T_pre[:3, 3] += [0.0, 0.0, 0.1]
    pre = planner.ik.solve(T_pre, q_now, np.random.default_rng(0))
    assert pre.success
    assert not planner.edge_free("transport")(q_now, pre.q)
    path, used_rrt, why = planner.joint_path(q_now, pre.q, "transport", np.random.default_rng(0))
    assert path is not None, why
    assert used_rrt
    edge = planner.edge_free("transport")
    assert all(edge(a, b) for a, b in itertools.pairwise(path))


def test_ik_test_checks_pregrasp_and_grasp_independently(fr3) -> None:
    _task, scene, planner = fr3
    planner.sync(PlanningWorld("target", check_table=True))
    q_now = scene.active_q("left")
    T_grasp = top_down_grasp(scene, "left")
    T_pre = T_grasp.copy()
    T_pre[:3, 3] += [0.0, 0.0, 0.05]
    rng = np.random.default_rng(0)
    ok = planner.test_ik(0, 3, 0.1, q_now, T_pre, T_grasp, True, rng)
    assert ok.feasible and ok.ik_pregrasp.success and ok.ik_grasp.success
    far = T_grasp.copy()
    far[:3, 3] += invert_T(scene.T_world_base("left"))[:3, :3].T @ np.array([2.0, 0.0, 0.0])
    bad = planner.test_ik(1, 4, 0.1, q_now, T_pre, far, True, rng)
    assert not bad.feasible and bad.stage == "ik_grasp"
    skipped = planner.test_ik(2, 5, 0.1, q_now, T_pre, far, False, rng)
    assert skipped.feasible and skipped.ik_grasp is None
