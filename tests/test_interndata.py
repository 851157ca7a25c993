"""InternDataEngine task files -> harness tasks: the real example files, the interpolation
resolver, the orientation table, and one clear located line for every kind of bad input."""

from __future__ import annotations

import logging
import math
import tempfile
from pathlib import Path
from typing import Any

import pytest
import yaml
from helpers import INTERNDATA_ROBOTS_TEXT
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from harness.config import AxisFilter, ConfigError, TaskConfig, parse_text
from harness.interndata import (
    CATEGORY_ORIENTATIONS,
    InternDataPick,
    load_interndata_tasks,
    parse_object_substitutions,
    random_orientations,
    resolve_interpolations,
    split_substitute,
    suggested_orientations,
)
from harness.robots.facts import interndata_home

PROJECT_ROOT = Path(__file__).resolve().parents[1]
ROBOTS_DIR = PROJECT_ROOT / "robots"

# The reference's canonical single-pick parameters (docs/reference-pick-skill.md sections 9 and 10).
CANONICAL = {
    "franka_single_pick_banana.yaml": {
        "robot_name": "franka",
        "robot": "fr3",
        "filters": {"filter_x_dir": ["forward", 90.0], "filter_z_dir": ["downward", 140.0]},
        "test_mode": "ik",
        "robot_pos": ((0.0, -0.495, 0.0), (0.0, -0.445, 0.05)),
        "object_pos": ((-0.3, -0.15, 0.0), (0.3, 0.15, 0.0)),
        "home": [0.0, -0.143, 0.0, -2.435, 0.0, 2.235, 0.789],
        "std": [0.0157, 0.0263, 0.0209, 0.0247, 0.0187, 0.0243, 0.0281],
    },
    "lift2_left_single_pick_banana.yaml": {
        "robot_name": "lift2",
        "robot": "lift2",
        "filters": {"filter_x_dir": ["downward", 140.0], "filter_z_dir": ["forward", 90.0]},
        "test_mode": "forward",
        "robot_pos": ((-0.025, -0.80, -0.775), (0.025, -0.80, -0.67)),
        "object_pos": ((-0.35, -0.25, 0.0), (0.05, 0.05, 0.0)),
        "home": [-0.00059017, 0.00374724, 0.00516233, 0.00025332, -0.00105036, -0.00132419],
        "std": [0.1] * 6,
    },
    "split_aloha_left_single_pick_banana.yaml": {
        "robot_name": "split_aloha",
        "robot": "split_aloha",
        "filters": {"filter_y_dir": ["forward", 90.0], "filter_z_dir": ["downward", 140.0]},
        "test_mode": "forward",
        "robot_pos": ((-0.025, -0.86, -0.765), (0.025, -0.86, -0.715)),
        "object_pos": ((-0.45, -0.25, 0.0), (0.05, 0.15, 0.0)),
        "home": [0.00484993, 0.34198609, -0.14007858, 0.01680429, 0.14391101, -0.00252178],
        "std": [0.12513939, 0.24539099, 0.24468172, 0.23398885, 0.2710117, 0.21726329],
    },
}


@pytest.fixture
def bottle(example_objects: list[Path]) -> Path:
    """The example bottle that stands in for the absent banana."""
    path = next(p for p in example_objects if p.name == "bottle_0") / "Aligned_obj.usd"
    assert path.is_file()
    return path


def example(examples_dir: Path, name: str) -> Path:
    return examples_dir / "tasks" / name


def copy_with(examples_dir: Path, name: str, tmp_path: Path, old: str, new: str) -> Path:
    """A copy of an example task file with one text replacement (which must apply)."""
    text = example(examples_dir, name).read_text()
    assert old in text, old
    path = tmp_path / name
    path.write_text(text.replace(old, new, 1))
    return path


def line_of(path: Path, fragment: str) -> int:
    """1-based line of the first line containing ``fragment``."""
    return next(i for i, line in enumerate(path.read_text().splitlines(), 1) if fragment in line)


# --------------------------------------------------------------------------------------------
# The three canonical single-pick files


@pytest.mark.parametrize("name", sorted(CANONICAL))
def test_canonical_single_pick(examples_dir: Path, bottle: Path, name: str) -> None:
    facts = CANONICAL[name]
    picks = load_interndata_tasks(
        example(examples_dir, name), None, {"pick_object_left": str(bottle)}
    )
    assert len(picks) == 1
    pick = picks[0]
    assert (pick.robot_name, pick.arm, pick.stage, pick.phase, pick.skill_index, pick.order) == (
        facts["robot_name"],
        "left",
        0,
        0,
        0,
        0,
    )
    assert pick.key == f"tasks[0].skills[0].{facts['robot_name']}[0].left[0]"
    task = pick.task
    assert (task.robot, task.arm, pick.robot) == (facts["robot"], "left", facts["robot"])
    assert task.name == Path(name).stem
    assert task.source == str(example(examples_dir, name))

    # The pick block, unchanged.
    block = task.pick
    filters = {key: spec.as_list() for key, spec in block.axis_filters().items()}
    assert filters == facts["filters"]
    assert block.objects == ["pick_object_left"]
    assert (block.pre_grasp_offset, block.gripper_change_steps) == (0.05, 10)
    assert (block.post_grasp_offset_min, block.post_grasp_offset_max) == (0.05, 0.20)
    assert (block.lift_th, block.t_eps, block.o_eps, block.process_valid) == (0.02, 0.01, 1, True)
    assert (block.test_mode, block.name, block.semantics) == (
        facts["test_mode"],
        "pick",
        "reference",
    )
    assert block.ignore_substring == []  # these robots set no planning ignore list

    # Robot: region + euler yaw, home and noise, no robot-table contact, episode length.
    assert task.robot_placement is not None
    assert task.robot_placement.pos_range == facts["robot_pos"]
    assert task.robot_placement.yaw_range == (90.0, 90.0)
    assert task.home == facts["home"]
    assert task.home_noise_std == facts["std"]
    assert task.physics.table_contact is False  # neglect_collision_names: [table]
    assert task.max_episode_length == 500

    # Object: the substitute, at scale 1, in the file's region, on its own category rule.
    assert [obj.name for obj in task.objects] == ["pick_object_left"]
    obj = task.objects[0]
    assert obj.mesh == str(bottle)
    assert obj.scale == (1.0, 1.0, 1.0)
    assert obj.placement is not None
    assert obj.placement.pos_range == facts["object_pos"]
    assert obj.placement.yaw_range == (-180.0, 180.0)
    assert obj.orientations == [(0.0, 0.0, 0.0)]  # 'recyclable_garbage' is not in the table
    assert obj.category == "recyclable_garbage"

    notes = "\n".join(pick.skipped)
    for key in ("env_map", "cameras", "arena_file"):
        assert f"ignored tasks[0].{key}: " in notes
    # distractors are rigid bodies (harness.interndata.distractors); their asset library
    # is not in the examples, so the scene goes without them, and says so
    assert "tasks[0].distractors: distractor folder not found" in notes
    assert "substitute 'pick_object_left' used at scale 1" in notes
    assert "skill" not in notes  # nothing but the pick in these files


@pytest.mark.parametrize("name", sorted(CANONICAL))
def test_canonical_files_match_the_robot_yaml_defaults(
    examples_dir: Path, bottle: Path, name: str
) -> None:
    """The robots' defaults are the canonical task values, so the mapping must reproduce them."""
    task = load_interndata_tasks(
        example(examples_dir, name), None, {"pick_object_left": str(bottle)}
    )[0].task
    robot_yaml = ROBOTS_DIR / task.robot / "robot.yaml"
    if not robot_yaml.is_file():
        pytest.skip(f"{robot_yaml} not written yet")
    robot = yaml.safe_load(robot_yaml.read_text())
    arm = robot["arms"]["left"]
    assert task.robot_placement is not None and task.objects[0].placement is not None
    assert [list(v) for v in task.robot_placement.pos_range] == robot["placement"]["pos_range"]
    assert list(task.robot_placement.yaw_range) == robot["placement"]["yaw_range"]
    assert task.home == arm["home"]
    assert task.home_noise_std == arm["home_noise_std"]
    assert [list(v) for v in task.objects[0].placement.pos_range] == arm["object_region"][
        "pos_range"
    ]


def test_banana_without_substitution_keeps_the_file_values(examples_dir: Path) -> None:
    """Validation mode (no asset check): the banana's own path, scale and suggested poses."""
    pick = load_interndata_tasks(
        example(examples_dir, "franka_single_pick_banana.yaml"), None, {}, check_assets=False
    )[0]
    obj = pick.task.objects[0]
    assert obj.mesh == (
        "pick_and_place/pre-train-pick/assets/omniobject3d-banana/omniobject3d-banana_001/"
        "Aligned_obj.usd"
    )
    assert obj.scale == (0.001, 0.001, 0.001)
    assert obj.category == "omniobject3d-banana"
    assert obj.orientations == [(0.0, 0.0, 0.0), (180.0, 0.0, 0.0)]  # banana x in {0, 180}


def test_asset_root_resolves_paths(examples_dir: Path, tmp_path: Path, bottle: Path) -> None:
    relative = "omniobject3d-banana/omniobject3d-banana_001/Aligned_obj.usd"
    path = copy_with(
        examples_dir,
        "franka_single_pick_banana.yaml",
        tmp_path,
        f"pick_and_place/pre-train-pick/assets/{relative}",
        relative,
    )
    asset = tmp_path / "assets" / relative
    asset.parent.mkdir(parents=True)
    asset.write_bytes(bottle.read_bytes())
    pick = load_interndata_tasks(path, tmp_path / "assets", {})[0]
    obj = pick.task.objects[0]
    assert obj.mesh == str(asset)
    assert obj.scale == (0.001, 0.001, 0.001)  # the file's own asset keeps the file's scale
    # The category comes from the asset's grandparent folder, as in the reference.
    assert obj.orientations == [(0.0, 0.0, 0.0), (180.0, 0.0, 0.0)]


# --------------------------------------------------------------------------------------------
# sort_the_rubbish: two arms, two phases, place and home skills


def sort_the_rubbish(examples_dir: Path, bottle: Path, example_objects: list[Path]) -> list:
    garbage = next(p for p in example_objects if p.name == "obj_1") / "Aligned_obj.usd"
    return load_interndata_tasks(
        example(examples_dir, "split_aloha_sort_the_rubbish.yaml"),
        None,
        {"pick_object_left": str(garbage), "pick_object_right": str(bottle)},
    )


def test_sort_the_rubbish_maps_both_arms_in_phase_order(
    examples_dir: Path, bottle: Path, example_objects: list[Path], caplog: pytest.LogCaptureFixture
) -> None:
    with caplog.at_level(logging.WARNING, logger="harness.interndata.resolver"):
        picks = sort_the_rubbish(examples_dir, bottle, example_objects)
    assert [(p.arm, p.stage, p.phase, p.skill_index, p.order) for p in picks] == [
        ("right", 0, 0, 0, 0),  # phase 0: the right arm's pick, place, home
        ("left", 0, 1, 0, 1),  # phase 1: the left arm's
    ]
    assert [p.key for p in picks] == [
        "tasks[0].skills[0].split_aloha[0].right[0]",
        "tasks[0].skills[0].split_aloha[1].left[0]",
    ]
    right, left = (p.task for p in picks)
    assert (right.robot, right.arm, right.pick.objects) == (
        "split_aloha",
        "right",
        ["pick_object_right"],
    )
    assert (left.robot, left.arm, left.pick.objects) == (
        "split_aloha",
        "left",
        ["pick_object_left"],
    )
    assert right.name == "split_aloha_sort_the_rubbish-0-right"
    for task in (right, left):
        pick = task.pick
        assert pick.filter_y_dir == AxisFilter(direction="forward", angles=(60,))
        assert pick.filter_z_dir == AxisFilter(direction="downward", angles=(150,))
        assert (pick.post_grasp_offset_min, pick.post_grasp_offset_max) == (0.10, 0.15)
        assert (pick.t_eps, pick.test_mode) == (0.025, "forward")
        # The robot's planning ignore list reaches the pick (the cans are ignored in planning).
        # the robot's list replaces the controllers' default; the pick's own adds to it
        assert pick.robot_ignore_substring == ["material", "table", "gso_box"]
        assert pick.ignore_substring == []
        assert task.max_episode_length == 4000
        assert task.robot_placement is not None
        assert task.robot_placement.pos_range == ((0.0, -0.86, -0.775), (0.0, -0.86, -0.725))
        # No home override in this file: the reference robot file's home, without noise.
        assert task.home == interndata_home("split_aloha", "left") == [0.0] * 6
        assert task.home_noise_std == [0.0] * 6
        # Both bottles are in both scenes; the garbage cans' assets are absent, so left out.
        assert [obj.name for obj in task.objects] == ["pick_object_left", "pick_object_right"]
        for obj in task.objects:
            assert obj.orientations == random_orientations()  # orientation_mode: random
            assert obj.placement is not None and obj.placement.yaw_range == (-180.0, 180.0)
    regions = {obj.name: obj.placement for obj in right.objects}
    assert regions["pick_object_left"].pos_range == ((-0.3, -0.2, 0.0), (-0.025, 0.1, 0.0))
    assert regions["pick_object_right"].pos_range == ((0.025, -0.2, 0.0), (0.3, 0.1, 0.0))

    for pick, arm, phase in ((picks[0], "right", 0), (picks[1], "left", 1)):
        notes = "\n".join(pick.skipped)
        for k, skill in ((1, "place"), (2, "heuristic__skill")):
            assert (
                f"skipped tasks[0].skills[0].split_aloha[{phase}].{arm}[{k}]: skill '{skill}'"
                in (notes)
            )
        assert "skipped object 'gso_box_left': asset not found" in notes
        assert "skipped object 'gso_box_right': asset not found" in notes
    warnings = [r.getMessage() for r in caplog.records]
    assert any("skipping 2 'place' skill(s)" in w for w in warnings)
    assert any("skipping 2 'heuristic__skill' skill(s)" in w for w in warnings)


def test_sort_the_rubbish_validates_without_assets(examples_dir: Path) -> None:
    picks = load_interndata_tasks(
        example(examples_dir, "split_aloha_sort_the_rubbish.yaml"), None, {}, check_assets=False
    )
    assert [p.arm for p in picks] == ["right", "left"]
    # Without an asset check every object with a table region stays in the scene.
    assert [o.name for o in picks[0].task.objects] == [
        "pick_object_left",
        "pick_object_right",
        "gso_box_left",
        "gso_box_right",
    ]
    can = picks[0].task.objects[2]
    assert can.orientations == [(90.0, 0.0, 0.0)]  # GeometryObject: its euler, kept
    assert can.placement is not None
    assert can.placement.pos_range == ((-0.6, 0.0, -0.75), (-0.6, 0.0, -0.75))


# --------------------------------------------------------------------------------------------
# Errors: one line naming the file and the key


def one_line_error(path: Path, *args: Any, **kwargs: Any) -> ConfigError:
    with pytest.raises(ConfigError) as info:
        load_interndata_tasks(path, *args, **kwargs)
    text = info.value.one_line()
    assert "\n" not in text
    assert text.startswith(f"{path}:")
    return info.value


def test_unsupported_robot(examples_dir: Path, tmp_path: Path, bottle: Path) -> None:
    path = copy_with(
        examples_dir,
        "franka_single_pick_banana.yaml",
        tmp_path,
        "robots/fr3.yaml",
        "robots/genie1.yaml",
    )
    err = one_line_error(path, None, {"pick_object_left": str(bottle)})
    line = line_of(path, "robot_config_file:")
    assert err.one_line() == (
        f"{path}:{line} tasks[0].robots[0].robot_config_file: unsupported robot 'genie1.yaml' "
        "(workflows/simbox/core/configs/robots/genie1.yaml); supported: " + INTERNDATA_ROBOTS_TEXT
    )


def test_missing_asset(examples_dir: Path, tmp_path: Path) -> None:
    path = example(examples_dir, "franka_single_pick_banana.yaml")
    err = one_line_error(path, tmp_path, {})
    line = line_of(path, "path: pick_and_place")
    expected_asset = tmp_path / (
        "pick_and_place/pre-train-pick/assets/omniobject3d-banana/omniobject3d-banana_001/"
        "Aligned_obj.usd"
    )
    assert err.one_line() == (
        f"{path}:{line} tasks[0].objects[0].path: asset not found: {expected_asset} "
        "(substitute it with --object pick_object_left=PATH)"
    )


def test_missing_substitute(examples_dir: Path, tmp_path: Path) -> None:
    path = example(examples_dir, "franka_single_pick_banana.yaml")
    err = one_line_error(path, None, {"pick_object_left": str(tmp_path / "none.usd")})
    assert err.key == "tasks[0].objects[0].path"
    assert err.message == f"substitute not found: {tmp_path / 'none.usd'} (check the --object path)"


def test_substitute_for_an_unknown_object(examples_dir: Path, bottle: Path) -> None:
    path = example(examples_dir, "franka_single_pick_banana.yaml")
    with pytest.raises(ConfigError) as info:
        load_interndata_tasks(path, None, {"pick_object_lft": str(bottle)}, check_assets=False)
    assert info.value.one_line() == (
        f"{path}: --object pick_object_lft: no object of that name in the file; did you mean "
        "'pick_object_left'? (objects: ['pick_object_left'])"
    )


@pytest.mark.parametrize(
    ("old", "new", "key_fragment", "message"),
    [
        (
            "object: ${tasks.0.robots.0.name}",
            "object: ${tasks.0.robots.1.name}",
            "object: ${tasks.0.robots.1.name}",
            "tasks[0].regions[1].object: interpolation ${tasks.0.robots.1.name}: key "
            "'tasks[0].robots[1]' not found (the list has 1 items)",
        ),
        (
            "object: ${tasks.0.robots.0.name}",
            "object: ${tasks.0.robot.0.name}",
            "object: ${tasks.0.robot.0.name}",
            "tasks[0].regions[1].object: interpolation ${tasks.0.robot.0.name}: key "
            "'tasks[0].robot' not found; did you mean 'robots'?",
        ),
        (
            'language_instruction: "Pick up the ${tasks.0.objects.0.name}."',
            'language_instruction: "Pick up the ${tasks.0.objects.0.nam}."',
            "language_instruction:",
            "tasks[0].data.language_instruction: interpolation ${tasks.0.objects.0.nam}: key "
            "'tasks[0].objects[0].nam' not found; did you mean 'name'?",
        ),
        (
            "object: ${tasks.0.robots.0.name}",
            "object: ${oc.env:ROBOT}",
            "object: ${oc.env:ROBOT}",
            "tasks[0].regions[1].object: interpolation ${oc.env:ROBOT}: resolver 'oc.env' is "
            "not supported",
        ),
        (
            "object: ${tasks.0.robots.0.name}",
            "object: ${tasks.0.robots.0.name",
            "object: ${tasks.0.robots.0.name",
            "tasks[0].regions[1].object: unterminated interpolation in "
            "'${tasks.0.robots.0.name' (missing '}')",
        ),
    ],
)
def test_broken_interpolation(
    examples_dir: Path, tmp_path: Path, old: str, new: str, key_fragment: str, message: str
) -> None:
    path = copy_with(examples_dir, "franka_single_pick_banana.yaml", tmp_path, old, new)
    err = one_line_error(path, None, {}, check_assets=False)
    assert err.one_line() == f"{path}:{line_of(path, key_fragment)} {message}"


def test_interpolation_cycle(examples_dir: Path, tmp_path: Path) -> None:
    path = copy_with(
        examples_dir, "franka_single_pick_banana.yaml", tmp_path, 'name: "franka"', "name: ${.name}"
    )
    err = one_line_error(path, None, {}, check_assets=False)
    assert err.key == "tasks[0].robots[0].name"
    assert err.message.startswith("interpolation cycle: tasks[0].robots[0].name -> ")


def test_pick_block_errors_point_into_the_file(examples_dir: Path, tmp_path: Path) -> None:
    path = copy_with(
        examples_dir,
        "franka_single_pick_banana.yaml",
        tmp_path,
        'filter_z_dir: ["downward", 140]',
        'filter_z_dir: ["down", 140]',
    )
    err = one_line_error(path, None, {}, check_assets=False)
    assert err.one_line() == (
        f"{path}:{line_of(path, 'filter_z_dir')} tasks[0].skills[0].franka[0].left[0]."
        "filter_z_dir: unknown direction 'down'; Pick knows only forward, backward, upward, "
        "downward"
    )
    path = copy_with(
        examples_dir,
        "franka_single_pick_banana.yaml",
        tmp_path,
        "post_grasp_offset_max: 0.20",
        "post_grasp_offset_max: 0.01",
    )
    err = one_line_error(path, None, {}, check_assets=False)
    assert err.line == line_of(path, "post_grasp_offset_max")
    assert err.key == "tasks[0].skills[0].franka[0].left[0].post_grasp_offset_max"
    path = copy_with(
        examples_dir, "franka_single_pick_banana.yaml", tmp_path, "t_eps: 0.01", "t_epss: 0.01"
    )
    err = one_line_error(path, None, {}, check_assets=False)
    assert (err.key, err.message) == (
        "tasks[0].skills[0].franka[0].left[0].t_epss",
        "unknown key; did you mean 't_eps'?",
    )


@pytest.mark.parametrize(
    ("old", "new", "fragment", "key", "message"),
    [
        (
            "objects: [pick_object_left]",
            "objects: [pick_object_lef]",
            "objects: [pick_object_lef]",
            "tasks[0].skills[0].franka[0].left[0].objects[0]",
            "unknown object 'pick_object_lef'; did you mean 'pick_object_left'? "
            "(objects: ['pick_object_left'])",
        ),
        (
            "            left:\n",
            "            right:\n",
            "right:",
            "tasks[0].skills[0].franka[0].right",
            "fr3 has no arm 'right' (arms: left)",
        ),
        (
            "        franka:\n",
            "        frank:\n",
            "frank:",
            "tasks[0].skills[0].frank",
            "skills for unknown robot 'frank'; did you mean 'franka'? (robots: ['franka'])",
        ),
        (
            "euler: [0.0, 0.0, 90.0]\n        left_joint_home",
            "euler: [10.0, 0.0, 90.0]\n        left_joint_home",
            "euler: [10.0",
            "tasks[0].robots[0].euler",
            "robot euler must be a pure yaw [0, 0, yaw] (the robot stands on the floor or table), "
            "got [10.0, 0.0, 90.0]",
        ),
        (
            "left_joint_home_std: [0.0157,",
            "left_joint_home_std: [-0.0157,",
            "left_joint_home_std",
            "tasks[0].robots[0].left_joint_home_std[0]",
            "Input should be greater than or equal to 0 (got -0.0157)",
        ),
        (
            "max_episode_length: 500",
            "max_episode_length: many",
            "max_episode_length",
            "tasks[0].data.max_episode_length",
            "Input should be a valid integer, unable to parse string as an integer (got 'many')",
        ),
        (
            "[0.3, 0.15, 0.0]",
            "[-0.5, 0.15, 0.0]",
            "pos_range: [",
            "tasks[0].regions[0].random_config.pos_range",
            "pos_range axis x: min -0.3 must be <= max -0.5",
        ),
        (
            "scale: [0.001, 0.001, 0.001]\n        apply",
            "scale: [0.001, 0.001]\n        apply",
            "scale: [0.001, 0.001]",
            "tasks[0].objects[0].scale",
            "too few values: item [2] is missing",
        ),
        (
            'orientation_mode: "suggested"',
            'orientation_mode: "sugested"',
            "orientation_mode",
            "tasks[0].objects[0].orientation_mode",
            "unknown orientation_mode 'sugested'; the reference knows keep, suggested, random",
        ),
    ],
)
def test_mapping_errors_are_located(
    examples_dir: Path, tmp_path: Path, old: str, new: str, fragment: str, key: str, message: str
) -> None:
    path = copy_with(examples_dir, "franka_single_pick_banana.yaml", tmp_path, old, new)
    err = one_line_error(path, None, {}, check_assets=False)
    assert (err.key, err.message) == (key, message)
    assert err.line == line_of(path, fragment)


def test_not_an_interndata_file(tmp_path: Path) -> None:
    path = tmp_path / "x.yaml"
    path.write_text("robot: fr3\n")
    err = one_line_error(path, None, {})
    assert err.message == "not an InternDataEngine task file (needs a non-empty 'tasks' list)"
    path.write_text("tasks:\n  - robots: []\n    skills: []\n")
    err = one_line_error(path, None, {})
    assert (err.key, err.line) == ("tasks[0].robots", 2)


def test_no_pick_skill(examples_dir: Path, tmp_path: Path) -> None:
    path = copy_with(
        examples_dir, "franka_single_pick_banana.yaml", tmp_path, "name: pick\n", "name: place\n"
    )
    err = one_line_error(path, None, {}, check_assets=False)
    assert (err.key, err.message) == (
        "tasks[0].skills",
        "no pick skill to run (pick-harness runs pick skills)",
    )


# --------------------------------------------------------------------------------------------
# Pieces


def resolved(text: str) -> Any:
    return resolve_interpolations(parse_text(text, "f.yaml"))


def test_interpolation_forms() -> None:
    data = resolved(
        "a:\n  list: [x, {name: deep}]\n  n: 3\n  flag: true\n"
        "b:\n"
        "  dotted: ${a.list.1.name}\n"
        "  bracket: ${a.list[1].name}\n"
        "  typed: ${a.n}\n"
        "  flag: ${a.flag}\n"
        "  whole: ${a.list}\n"
        "  text: n=${a.n}, flag=${a.flag}!\n"
        "  relative: ${.typed}\n"
        "  up: ${..a.n}\n"
        "  key: list\n"
        "  nested: ${a.${.key}.0}\n"
        "  chained: ${b.relative}\n"
        "  escaped: \\${a.n} costs ${a.n}\n"
    )
    assert data["b"] == {
        "dotted": "deep",
        "bracket": "deep",
        "typed": 3,
        "flag": True,
        "whole": ["x", {"name": "deep"}],
        "text": "n=3, flag=True!",
        "relative": 3,
        "up": 3,
        "key": "list",
        "nested": "x",
        "chained": 3,
        "escaped": "${a.n} costs 3",
    }


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("a: ${}\n", "empty interpolation ${}"),
        ("a: [1]\nb: x${a}\n", "interpolation ${a} is a list; only a whole string can take"),
        ("a: ${a}\n", "interpolation cycle: a -> a"),
        ("a: ${b}\nb: ${a}\n", "interpolation cycle: a -> b -> a"),
        ("a: 1\nb: ${a.c}\n", "interpolation ${a.c}: key 'a.c' not found (int has no keys)"),
        ("a: ${x..y}\n", "interpolation ${x..y} is not a key path"),
    ],
)
def test_interpolation_errors(text: str, message: str) -> None:
    with pytest.raises(ConfigError) as info:
        resolved(text)
    assert info.value.message.startswith(message), info.value.message
    assert info.value.file == "f.yaml"


def test_orientation_table() -> None:
    assert suggested_orientations("omniobject3d-banana") == [(0, 0, 0), (180, 0, 0)]
    assert suggested_orientations("omniobject3d-mug") == [(90, 0, 0)]
    assert suggested_orientations("omniobject3d-knife") == [(0, 90, 0), (0, 270, 0)]
    assert suggested_orientations("pnp_basket") == [(90, 0, 90)]
    assert suggested_orientations("unknown-category") == [(0, 0, 0)]
    assert len(suggested_orientations("google_scan-book")) == 4
    assert len(CATEGORY_ORIENTATIONS) == 139
    for rule in CATEGORY_ORIENTATIONS.values():
        assert set(rule) <= {"x", "y", "z"}
        assert all(angle % 90 == 0 for angles in rule.values() for angle in angles)


def test_random_orientation_grid() -> None:
    grid = random_orientations()
    assert len(grid) == 144 and len(set(grid)) == 144
    assert {x for x, _, _ in grid} == {float(a) for a in range(-180, 180, 30)}
    assert {z for _, _, z in grid} == {0.0}


def test_object_substitution_parsing() -> None:
    assert parse_object_substitutions(["a=/x/y.usd", " b = z.usd "]) == {
        "a": "/x/y.usd",
        "b": "z.usd",
    }
    for bad in ("a", "=x", "a="):
        with pytest.raises(ConfigError, match="expected NAME=PATH"):
            parse_object_substitutions([bad])
    assert split_substitute("/x/y.usd") == ("/x/y.usd", None)
    assert split_substitute("/x/y.usd@0.001") == ("/x/y.usd", (0.001, 0.001, 0.001))
    assert split_substitute("/x/y.usd@1,2,3") == ("/x/y.usd", (1.0, 2.0, 3.0))
    assert split_substitute("/x@home/y.usd") == ("/x@home/y.usd", None)
    for bad in ("/x.usd@0", "/x.usd@1,2", "/x.usd@-1", f"/x.usd@{math.inf}"):
        with pytest.raises(ConfigError, match="scale must be one or three positive numbers"):
            split_substitute(bad)


def test_substitute_scale_is_used(examples_dir: Path, bottle: Path) -> None:
    pick = load_interndata_tasks(
        example(examples_dir, "franka_single_pick_banana.yaml"),
        None,
        {"pick_object_left": f"{bottle}@0.5"},
    )[0]
    assert pick.task.objects[0].scale == (0.5, 0.5, 0.5)
    assert pick.task.objects[0].mesh == str(bottle)
    assert not any("used at scale 1" in note for note in pick.skipped)


def test_result_type(examples_dir: Path) -> None:
    pick = load_interndata_tasks(
        example(examples_dir, "lift2_left_single_pick_banana.yaml"), None, {}, check_assets=False
    )[0]
    assert isinstance(pick, InternDataPick)
    assert isinstance(pick.task, TaskConfig)
    # A mapped task round-trips through the harness config like any task.
    assert TaskConfig.model_validate(pick.task.model_dump()) == pick.task


# --------------------------------------------------------------------------------------------
# Property test: any edit of a real file maps or fails with a ConfigError

LEAVES = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(10**20), 10**20),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=8),
    st.sampled_from(["${tasks.0.robots.0.name}", "${x}", "${", "pick", "left", "fr3.yaml"]),
    st.lists(st.floats(-2, 200), max_size=4),
)


def _paths(node: Any, prefix: tuple = ()) -> list[tuple]:
    out = [prefix]
    if isinstance(node, dict):
        for key, value in node.items():
            out += _paths(value, (*prefix, key))
    elif isinstance(node, list):
        for index, value in enumerate(node):
            out += _paths(value, (*prefix, index))
    return out


@settings(
    max_examples=max(60, settings.default.max_examples),  # more with --hypothesis-profile=bughunt
    deadline=None,
    suppress_health_check=list(HealthCheck),
    database=None,
)
@given(st.data())
def test_edited_files_map_or_fail_cleanly(examples_dir: Path, data: st.DataObject) -> None:
    name = data.draw(st.sampled_from([*sorted(CANONICAL), "split_aloha_sort_the_rubbish.yaml"]))
    document = yaml.safe_load(example(examples_dir, name).read_text())
    for _ in range(data.draw(st.integers(1, 3))):
        paths = [p for p in _paths(document) if p]
        target = data.draw(st.sampled_from(paths))
        node = document
        for step in target[:-1]:
            node = node[step]
        node[target[-1]] = data.draw(LEAVES)
    text = yaml.safe_dump(document, sort_keys=False)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / name
        path.write_text(text)
        try:
            picks = load_interndata_tasks(path, None, {}, check_assets=False)
        except ConfigError as exc:
            assert "\n" not in exc.one_line()
        else:
            assert picks and all(isinstance(p.task, TaskConfig) for p in picks)


def test_relative_paths_resolve_against_the_current_directory(
    examples_dir: Path, bottle: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Like the reference (and a shell user), relative asset roots and substitutes are taken
    from the current directory; the task then holds absolute paths, so it can move."""
    (tmp_path / "assets").mkdir()
    (tmp_path / "assets" / "bottle.usd").write_bytes(bottle.read_bytes())
    monkeypatch.chdir(tmp_path)
    pick = load_interndata_tasks(
        example(examples_dir, "franka_single_pick_banana.yaml"),
        Path("assets"),
        {"pick_object_left": "assets/bottle.usd"},
    )[0]
    assert pick.task.objects[0].mesh == str(tmp_path / "assets" / "bottle.usd")


def test_compatibility_table_lists_every_key_the_mapper_knows() -> None:
    from harness import interndata

    text = (PROJECT_ROOT / "docs" / "interndata.md").read_text()
    keys = [
        *interndata.TASK_KEYS_MAPPED,
        *interndata.TASK_KEYS_IGNORED,
        *interndata.ROBOT_KEYS_IGNORED,
        *interndata.OBJECT_KEYS_IGNORED,
    ]
    missing = [key for key in keys if f"`{key}`" not in text]
    assert not missing, f"docs/interndata.md does not mention {missing}"
