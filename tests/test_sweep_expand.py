"""Sweep expansion: points, deterministic ids and seeds, overrides, located errors."""

from __future__ import annotations

from pathlib import Path

import pytest

from harness.config import ConfigError, SweepConfig
from harness.episode.ids import episode_id, episode_seed
from harness.runs.expansion import expand, select_samples, sweep_points

TASK = {
    "name": "t",
    "robot": "fr3",
    "objects": [{"name": "cube", "mesh": "cube"}],
    "pick": {"filter_z_dir": ["downward", 140]},
}


def make_sweep(**kwargs) -> SweepConfig:
    data = {"name": "s", "tasks": [TASK], "episodes_per_point": 3, **kwargs}
    return SweepConfig.model_validate(data)


def test_grid_is_the_cartesian_product_in_axis_order():
    sweep = make_sweep(axes={"pick.pre_grasp_offset": [0.05, 0.1], "object.friction": [0.5, 1, 2]})
    points = sweep_points(sweep)
    assert len(points) == 6
    assert points[0] == {"pick.pre_grasp_offset": 0.05, "object.friction": 0.5}
    assert points[1] == {"pick.pre_grasp_offset": 0.05, "object.friction": 1}
    assert points[-1] == {"pick.pre_grasp_offset": 0.1, "object.friction": 2}


def test_random_points_are_seeded_and_within_bounds():
    spec = {
        "pick.pre_grasp_offset": {"low": 0.02, "high": 0.1},
        "pick.approach_filter": {"choices": [["downward", 120], ["downward", 160]]},
    }
    a = sweep_points(make_sweep(mode="random", random_axes=spec, points=20, seed=3))
    b = sweep_points(make_sweep(mode="random", random_axes=spec, points=20, seed=3))
    c = sweep_points(make_sweep(mode="random", random_axes=spec, points=20, seed=4))
    assert a == b and a != c
    assert all(0.02 <= p["pick.pre_grasp_offset"] <= 0.1 for p in a)
    assert {tuple(p["pick.approach_filter"]) for p in a} == {("downward", 120), ("downward", 160)}


def test_expand_applies_overrides_and_ids_are_deterministic():
    sweep = make_sweep(
        axes={
            "pick.approach_filter": [["downward", 120], ["downward", 160]],
            "object.mass": [0.05, 0.2],
        }
    )
    episodes = expand(sweep, None)
    assert len(episodes) == 1 * 4 * 3
    assert len({e.episode_id for e in episodes}) == len(episodes)
    again = expand(sweep, None)
    assert [e.episode_id for e in again] == [e.episode_id for e in episodes]
    first = episodes[0]
    assert first.task.pick.approach_filter.as_list() == ["downward", 120.0]
    assert first.task.objects[0].mass == 0.05
    # Common random numbers: episode k has the same seed at every point.
    by_index = {}
    for e in episodes:
        by_index.setdefault(e.episode_index, set()).add(e.seed)
    assert all(len(seeds) == 1 for seeds in by_index.values())
    assert len({next(iter(s)) for s in by_index.values()}) == 3


def test_seed_and_id_functions():
    assert episode_seed(0, 1) == episode_seed(0, 1) != episode_seed(1, 1)
    assert episode_id("t", {"a": 1}, 0) != episode_id("t", {"a": 2}, 0)
    assert episode_id("t", {"a": 1}, 0).startswith("t-e0000-")


def test_override_that_breaks_validation_names_the_axis(tmp_path: Path):
    sweep = make_sweep(axes={"pick.filter_z_dir": [["down", 140]]})
    with pytest.raises(ConfigError) as info:
        expand(sweep, tmp_path / "s.yaml")
    assert "axes.pick.filter_z_dir" in str(info.value)
    assert "unknown direction" in str(info.value)


def test_unknown_axis_key_is_rejected_with_suggestion():
    with pytest.raises(ValueError, match="did you mean 'pre_grasp_offset'"):
        make_sweep(axes={"pick.pre_grasp_ofset": [0.1]})


def test_sample_selection_is_deterministic_and_sized():
    episodes = expand(make_sweep(episodes_per_point=10), None)
    chosen = select_samples(episodes, 4)
    assert len(chosen) == 4 and chosen == select_samples(episodes, 4)
    tagged = expand(make_sweep(episodes_per_point=10, record="sample:4"), None)
    assert {e.episode_id for e in tagged if e.record} == chosen


def test_neutral_axis_replaces_each_robots_own_filter_on_that_axis():
    lift2 = {
        **TASK,
        "name": "l",
        "robot": "lift2",
        "pick": {"filter_x_dir": ["downward", 140], "filter_z_dir": ["forward", 90]},
    }
    fr3 = {**TASK, "pick": {"filter_x_dir": ["forward", 90], "filter_z_dir": ["downward", 140]}}
    sweep = make_sweep(
        tasks=[fr3, lift2], episodes_per_point=1, axes={"pick.approach_filter": [["downward", 160]]}
    )
    by_robot = {e.task.robot: e.task.pick for e in expand(sweep, None)}
    # fr3 approaches along EE z, lift2 along EE x: each loses exactly that explicit filter.
    assert by_robot["fr3"].filter_z_dir is None
    assert by_robot["fr3"].filter_x_dir.as_list() == ["forward", 90.0]
    assert by_robot["lift2"].filter_x_dir is None
    assert by_robot["lift2"].filter_z_dir.as_list() == ["forward", 90.0]
    assert by_robot["lift2"].approach_filter.as_list() == ["downward", 160.0]


def test_explicit_axis_replaces_a_neutral_filter_on_the_same_axis():
    neutral = {**TASK, "pick": {"approach_filter": ["downward", 140]}}
    sweep = make_sweep(tasks=[neutral], axes={"pick.filter_z_dir": [["downward", 120]]})
    pick = expand(sweep, None)[0].task.pick
    assert pick.approach_filter is None and pick.filter_z_dir.as_list() == ["downward", 120.0]


def test_a_task_filtering_one_axis_twice_fails_at_expansion(tmp_path: Path):
    clash = {
        **TASK,
        "pick": {"approach_filter": ["downward", 140], "filter_z_dir": ["downward", 120]},
    }
    with pytest.raises(ConfigError, match="set only one of them"):
        expand(make_sweep(tasks=[clash]), tmp_path / "s.yaml")


def test_swapping_the_mesh_renames_the_target_object():
    sweep = make_sweep(
        axes={"object.mesh": ["cube", "banana", "/data/meshes/mug.obj"]}, episodes_per_point=1
    )
    tasks = [e.task for e in expand(sweep, None)]
    assert [t.target_object.name for t in tasks] == ["cube", "banana", "mug"]
    assert [t.pick.objects for t in tasks] == [["cube"], ["banana"], ["mug"]]
    assert tasks[2].objects[0].mesh == "/data/meshes/mug.obj"


def test_object_keys_mean_the_picked_object_not_the_first() -> None:
    """object.* in --set and sweep axes is the picked object (pick.objects[0]), wherever it is
    in the scene's object list; objects.0.* stays the first object."""
    from harness.config import TaskConfig
    from harness.config.overrides import apply_overrides

    scene = {
        **TASK,
        "objects": [{"name": "cube", "mesh": "cube"}, {"name": "banana", "mesh": "banana"}],
        "pick": {"objects": ["banana"]},
    }
    task = TaskConfig.model_validate(scene)
    changed = apply_overrides(task, {"object.mass": 0.5, "object.friction": 0.7})
    assert [(o.name, o.mass, o.friction) for o in changed.objects] == [
        ("cube", None, None),  # not given: the asset's (object.yaml) values apply
        ("banana", 0.5, 0.7),
    ]
    first = apply_overrides(task, {"objects.0.mass": 0.3})
    assert [o.mass for o in first.objects] == [0.3, None]

    sweep = make_sweep(tasks=[scene], axes={"object.mesh": ["banana", "mug"]}, episodes_per_point=1)
    tasks = [e.task for e in expand(sweep, None)]
    assert [t.target_object.name for t in tasks] == ["banana", "mug"]
    assert [[o.name for o in t.objects] for t in tasks] == [["cube", "banana"], ["cube", "mug"]]
    assert [t.target_object.mesh for t in tasks] == ["banana", "mug"]
    assert [t.objects[0].mesh for t in tasks] == ["cube", "cube"]
