"""What a scene holds, as the reference has it: object mass and friction from the USD, fixtures
(the reference's GeometryObject) static, distractors as rigid bodies and planning obstacles,
preflight accepting what the reference runs, and a pick that depends on earlier skills kept out
of rates (issue 22 items 3, 6, 7)."""

from __future__ import annotations

import copy
import itertools
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from helpers import make_task, scene_planner, top_down_grasp, write_box

from harness.config import PickConfig
from harness.episode.pipeline import run_episode
from harness.episode.spec import EpisodeSpec
from harness.errors import InputFileError
from harness.interndata import load_interndata_tasks
from harness.objects.assets import ObjectAsset
from harness.objects.usd_physics import read_usd_physics
from harness.pick.semantics import Semantics
from harness.report.tables import rated, summarize
from harness.runs.preflight import check_task, check_tasks
from harness.sim import Scene


def _substitutes(examples: Path) -> dict[str, str]:
    objects = examples / "objects"
    return {
        "pick_object_left": str(objects / "non_recyclable_garbage/obj_1/Aligned_obj.usd"),
        "pick_object_right": str(objects / "recyclable_garbage/bottle_0/Aligned_obj.usd"),
    }


# --------------------------------------------------------------------------------------------
# Item 3: mass and friction from the USD


def test_every_example_usd_authors_half_a_kilo_and_friction_one(
    example_objects: list[Path],
) -> None:
    for folder in example_objects:
        physics = read_usd_physics(folder / "Aligned_obj.usd")
        assert (physics.mass, physics.static_friction, physics.dynamic_friction) == (0.5, 1.0, 1.0)
    assert read_usd_physics(folder / "Aligned_grasp_sparse.npy").mass is None  # not a USD


def test_an_asset_takes_the_usds_physics_unless_the_task_sets_it(examples_dir: Path) -> None:
    bottle = examples_dir / "objects/recyclable_garbage/bottle_0/Aligned_obj.usd"
    own = ObjectAsset.load(bottle)
    assert (own.mass, own.friction) == (0.5, 1.0)
    given = ObjectAsset.load(bottle, mass=0.2, friction=0.6)
    assert (given.mass, given.friction) == (0.2, 0.6)


def test_interndata_objects_simulate_the_usd_mass_or_the_files_mass_key(
    examples_dir: Path, tmp_path: Path
) -> None:
    source = examples_dir / "tasks/franka_single_pick_banana.yaml"
    subs = {"pick_object_left": _substitutes(examples_dir)["pick_object_right"]}
    (pick,) = load_interndata_tasks(source, asset_root=None, objects=subs)
    assert pick.task.objects[0].mass is None  # not in the file: the USD decides
    scene = Scene.build(pick.task.robot, pick.task.objects, pick.task.physics)
    body = scene.objects["pick_object_left"]
    assert scene.model.body_mass[body.body_id] == pytest.approx(0.5)
    assert scene.model.geom_friction[body.geom_ids[0], 0] == pytest.approx(1.0)

    data = yaml.safe_load(source.read_text(encoding="utf-8"))
    data["tasks"][0]["objects"][0]["mass"] = 0.3  # the reference passes it to its RigidPrim
    edited = tmp_path / "with_mass.yaml"
    edited.write_text(yaml.safe_dump(data), encoding="utf-8")
    (pick,) = load_interndata_tasks(edited, asset_root=None, objects=subs)
    assert pick.task.objects[0].mass == 0.3


# --------------------------------------------------------------------------------------------
# Item 6: fixtures, distractors, preflight


@pytest.fixture(scope="module")
def fixture_scene(tmp_path_factory: pytest.TempPathFactory):
    """FR3, its target, and a 10 cm box fixture (``fixed``) 15 cm to the side."""
    folder = tmp_path_factory.mktemp("fixture")
    cube = write_box(folder / "cube", (0.04, 0.04, 0.04), "cube")
    box = write_box(folder / "bin", (0.1, 0.1, 0.1), "bin")
    at = {"placement": {"pos_range": [[0.15, 0.0, 0.0], [0.15, 0.0, 0.0]], "yaw_range": [0, 0]}}
    task = make_task(
        "fr3",
        "left",
        cube,
        object={"placement": {"pos_range": [[-0.1, 0, 0], [-0.1, 0, 0]], "yaw_range": [0, 0]}},
        extra_objects=[{"name": "bin", "mesh": str(box), "fixed": True, **at}],
    )
    scene, planner = scene_planner(task)
    return task, scene, planner


def test_a_fixture_is_a_static_body_that_never_moves(fixture_scene) -> None:
    task, scene, _ = fixture_scene
    fixture = scene.objects["bin"]
    assert fixture.fixed and fixture.qpos_adr == -1
    assert scene.model.body_jntnum[fixture.body_id] == 0  # no free joint: static
    scene.reset(task, np.random.default_rng(0))
    start = scene.T_world_object("bin").copy()
    np.testing.assert_allclose(start[:3, 3], [0.15, 0.0, 0.051], atol=1e-9)  # 1 mm above the top
    scene.step(500)  # 1 s under gravity
    np.testing.assert_array_equal(scene.T_world_object("bin"), start)
    assert scene.model.body_mass[scene.objects["target"].body_id] > 0


def test_a_fixture_is_an_obstacle_of_the_reference_planning_world(fixture_scene) -> None:
    task, scene, planner = fixture_scene
    scene.reset(task, np.random.default_rng(0))
    planner.sync(Semantics.from_pick(PickConfig()).planning_world("target"))
    T = top_down_grasp(scene, "left", "bin")
    T[:3, 3] += [0.0, 0.0, -0.03]  # the palm into the bin
    result = planner.ik.solve(T, scene.active_q("left"), np.random.default_rng(0))
    assert result.success
    assert planner.checker.collides(result.q, "transport")
    assert "bin" in planner.checker.describe(planner.checker.contacts(result.q, "transport"))


def test_objects_with_min_distance_keep_it_from_those_placed_before(tmp_path: Path) -> None:
    """The reference's distractors keep min_object_distance from every other object."""
    box = write_box(tmp_path / "box", (0.06, 0.06, 0.06), "box")
    region = {"pos_range": [[0.0, 0.0, 0.0], [0.3, 0.3, 0.0]], "yaw_range": [-180, 180]}
    extra = [
        {"name": f"d{i}", "mesh": str(box), "placement": region, "min_distance": 0.03}
        for i in range(4)
    ]
    task = make_task("fr3", "left", box, object={"placement": region}, extra_objects=extra)
    scene = Scene.build(task.robot, task.objects, task.physics)
    radius = float(np.linalg.norm([0.03, 0.03]))  # a 6 cm box's circle, whatever the yaw
    for seed in range(5):
        state = scene.reset(task, np.random.default_rng(seed))
        xy = {name: T[:2, 3] for name, T in state.T_world_objects.items()}
        for a, b in itertools.combinations(xy, 2):
            gap = np.linalg.norm(xy[a] - xy[b]) - 2 * radius  # b was placed after a
            assert gap >= 0.03 - 1e-9, (seed, a, b, gap)


def test_distractors_are_rigid_bodies_and_planning_obstacles(
    examples_dir: Path, tmp_path: Path
) -> None:
    """With the distractor library present (here: the example objects, <path>/<category>/<name>),
    the file's distractors become free objects on its pos_range, min_object_distance apart."""
    source = examples_dir / "tasks/franka_single_pick_banana.yaml"
    data = yaml.safe_load(source.read_text(encoding="utf-8"))
    data["tasks"][0]["distractors"]["path"] = "objects"
    data["tasks"][0]["distractors"]["scale"] = [1.0, 1.0, 1.0]
    edited = tmp_path / "with_distractors.yaml"
    edited.write_text(yaml.safe_dump(data), encoding="utf-8")
    xy_low, xy_high = (tuple(row) for row in data["tasks"][0]["distractors"]["pos_range"])
    subs = {"pick_object_left": _substitutes(examples_dir)["pick_object_right"]}
    (pick,) = load_interndata_tasks(edited, asset_root=examples_dir, objects=subs)
    distractors = [o for o in pick.task.objects if o.name.startswith("distractors_")]
    available = len(list((examples_dir / "objects").glob("*/*/*.usd")))  # none excluded
    assert len(distractors) == (5 + min(10, available)) // 2  # min_num 5, max_num 10
    for obj in distractors:
        assert not obj.fixed and obj.min_distance == 0.03
        assert obj.placement is not None
        assert obj.placement.pos_range == (((*xy_low, 0.0)), (*xy_high, 0.0))
        assert Path(obj.mesh).is_file()
    world = Semantics.from_pick(pick.task.pick).planning_world("pick_object_left")
    assert not any(s in obj.name for obj in distractors for s in world.ignore_substring)
    assert any("distractors drawn once for this task" in note for note in pick.skipped)


def _rubbish_with_bins(examples_dir: Path) -> list:
    subs = _substitutes(examples_dir)
    objects = examples_dir / "objects"
    subs["gso_box_left"] = str(objects / "non_recyclable_garbage/obj_2/Aligned_obj.usd")
    subs["gso_box_right"] = str(objects / "non_recyclable_garbage/obj_3/Aligned_obj.usd")
    return load_interndata_tasks(
        examples_dir / "tasks/split_aloha_sort_the_rubbish.yaml", asset_root=None, objects=subs
    )


def test_the_rubbish_file_with_its_bins_passes_preflight(examples_dir: Path) -> None:
    """Its GeometryObject bins stand 0.75 m down at x = +-0.6: static fixtures, accepted (with a
    warning: the harness table is wider than the reference arena's), never refused."""
    picks = _rubbish_with_bins(examples_dir)
    for pick in picks:
        bins = [o for o in pick.task.objects if o.name.startswith("gso_box")]
        assert [o.fixed for o in bins] == [True, True]
        assert all(o.placement and o.placement.pos_range[0][2] == -0.75 for o in bins)
    warnings = check_tasks([pick.task for pick in picks])
    assert len(warnings) == 2
    assert all("may start up to 750 mm inside the table" in line for line in warnings)


def test_preflight_accepts_beside_the_table_and_refuses_only_wholly_inside(
    tmp_path: Path,
) -> None:
    cube = write_box(tmp_path / "cube", (0.04, 0.04, 0.04), "cube")

    def task_with(x: float, fixed: bool):
        other = {
            "name": "other",
            "mesh": str(cube),
            "fixed": fixed,
            "placement": {"pos_range": [[x, 0.0, -0.75], [x, 0.0, -0.75]]},
        }
        return make_task("fr3", "left", cube, extra_objects=[other])

    assert check_task(task_with(1.2, fixed=True)) == []  # beside the 1.6 m table: a fixture
    (line,) = check_task(task_with(1.2, fixed=False))
    assert "beside the table" in line and "no floor" in line
    (line,) = check_task(task_with(0.5, fixed=True))
    assert "may start up to 750 mm inside the table" in line
    with pytest.raises(InputFileError, match="750 mm inside the table"):
        check_task(task_with(0.5, fixed=False))


# --------------------------------------------------------------------------------------------
# Item 7: a pick that depends on earlier skills


def _pick_after_place(examples_dir: Path, tmp_path: Path) -> Path:
    """The Split ALOHA file with a pick that depends on earlier skills and is no handover: the
    left arm picks the object and places it, then the right arm picks it from where it lies.
    (A handover -- the left pick, optionally its goto__pose, then the right pick -- runs:
    tests/test_handover.py.)"""
    source = examples_dir / "tasks/split_aloha_left_single_pick_banana.yaml"
    data = yaml.safe_load(source.read_text(encoding="utf-8"))
    stage = data["tasks"][0]["skills"][0]["split_aloha"]
    pick = stage[0]["left"][0]
    right = copy.deepcopy(pick)
    right.pop("filter_y_dir", None)
    stage[0]["left"].append({"name": "place", "objects": ["pick_object_left"]})
    stage.append({"right": [right]})
    path = tmp_path / "pick_after_place.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return path


def test_a_pick_after_a_place_is_not_runnable_and_in_no_rate(
    examples_dir: Path, tmp_path: Path
) -> None:
    subs = {"pick_object_left": _substitutes(examples_dir)["pick_object_right"]}
    first, second = load_interndata_tasks(
        _pick_after_place(examples_dir, tmp_path), asset_root=None, objects=subs
    )
    assert first.task.not_runnable is None
    assert second.task.handover is None
    reason = second.task.not_runnable
    assert reason is not None
    assert reason.startswith(
        "tasks[0].skills[0].split_aloha[1].right[0] picks 'pick_object_left', which "
        "tasks[0].skills[0].split_aloha[0].left[1] (place, split_aloha left arm) handles before it"
    )
    assert any(reason in note for note in second.skipped)
    rows = []
    for seed in range(2):
        result = run_episode(EpisodeSpec(task=second.task, seed=seed, episode_index=seed))
        assert result.row["failure_reason"] == "not_runnable"
        assert result.row["error_message"] == reason and not result.row["success"]
        rows.append(result.row)
    frame = pd.DataFrame(rows)
    assert rated(frame).empty
    summary = summarize(frame)
    assert int(summary["n"].sum()) == 0 and int(summary["errors"].sum()) == 0
