"""Config models: every validation rule, located one-line errors, and a loader that never crashes.

Each rule of the ``harness.config`` models has a test that shows it accepting good input and
rejecting bad input with a message that explains the fix. Errors are checked in their final form,
``file:line key.path: message``. A hypothesis section feeds random documents and random values
for every key through the loaders: they either accept or raise ``ConfigError``, nothing else.
"""

from __future__ import annotations

import atexit
import math
import re
import shutil
import tempfile
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from harness.config import (
    DIRECTIONS,
    AxisFilter,
    ConfigError,
    ObjectConfig,
    PhysicsConfig,
    PickConfig,
    Placement,
    RandomAxis,
    SweepConfig,
    TaskConfig,
    apply_overrides,
    kind_of,
    load_any,
    load_sweep,
    load_task,
    parse_set_value,
    parse_text,
    set_dotted,
    validate_model,
)

PROJECT_ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = PROJECT_ROOT / "tasks" / "examples"
DOCS = PROJECT_ROOT / "docs" / "config.md"

BASE_TASK: dict[str, Any] = {"robot": "fr3", "objects": [{"name": "cube", "mesh": "cube"}]}


def task(**changes: Any) -> dict[str, Any]:
    """A valid task dict with top-level changes."""
    return {**BASE_TASK, **changes}


def pick(**keys: Any) -> dict[str, Any]:
    """A valid task dict with the given pick block."""
    return task(pick=keys)


def check(model: type, data: Any) -> Any:
    """Validate without a document (errors carry the key path but no file or line)."""
    return validate_model(model, data)


def error(model: type, data: Any) -> ConfigError:
    with pytest.raises(ConfigError) as info:
        validate_model(model, data)
    return info.value


def located(text: str, model: type = TaskConfig, path: str = "t.yaml") -> ConfigError:
    """The error of a YAML text, located in a pretend file."""
    doc = parse_text(text, path)
    with pytest.raises(ConfigError) as info:
        validate_model(model, doc.data, doc)
    return info.value


# --------------------------------------------------------------------------------------------
# Direction filters


@pytest.mark.parametrize(
    "key", ["filter_x_dir", "filter_y_dir", "filter_z_dir", "approach_filter", "facing_filter"]
)
@pytest.mark.parametrize("direction", DIRECTIONS)
def test_every_direction_on_every_filter_key(key: str, direction: str) -> None:
    config = check(TaskConfig, pick(**{key: [direction, 120]})).pick
    spec = getattr(config, key)
    assert spec == AxisFilter(direction=direction, angles=(120.0,))
    assert not spec.is_band
    assert PickConfig.model_validate({key: [direction, 30, 60]}).model_dump()[key] == [
        direction,
        30.0,
        60.0,
    ]


@pytest.mark.parametrize("direction", ["leftward", "rightward", "down", "Forward", "", None, 1])
def test_unknown_direction_lists_the_four_pick_knows(direction: Any) -> None:
    err = error(TaskConfig, pick(filter_y_dir=[direction, 90]))
    assert err.key == "pick.filter_y_dir"
    assert err.message == (
        f"unknown direction {direction!r}; Pick knows only forward, backward, upward, downward"
    )


def test_two_and_three_element_forms() -> None:
    config = PickConfig(filter_x_dir=["forward", 90], filter_z_dir=["downward", 110, 140])
    assert config.filter_x_dir is not None and config.filter_z_dir is not None
    assert config.filter_x_dir.angles == (90.0,) and not config.filter_x_dir.is_band
    assert config.filter_z_dir.angles == (110.0, 140.0) and config.filter_z_dir.is_band
    assert config.axis_filters() == {
        "filter_x_dir": config.filter_x_dir,
        "filter_z_dir": config.filter_z_dir,
    }
    assert config.model_dump()["filter_z_dir"] == ["downward", 110.0, 140.0]
    # The model_dump form loads back to the same config (sweeps and run dirs rely on this).
    assert PickConfig.model_validate(config.model_dump()) == config
    # The mapping form is accepted too.
    assert PickConfig(filter_x_dir={"direction": "forward", "angles": [90]}) == PickConfig(
        filter_x_dir=["forward", 90]
    )


@pytest.mark.parametrize("value", [["forward"], ["forward", 1, 2, 3], "forward", 90, [], {"a": 1}])
def test_filter_shape_errors(value: Any) -> None:
    err = error(TaskConfig, pick(filter_x_dir=value))
    assert err.key is not None and err.key.startswith("pick.filter_x_dir")
    if not isinstance(value, dict):
        assert "expected [direction, angle] or [direction, angle1, angle2]" in err.message


@pytest.mark.parametrize("angle", [0, 0.0, 45, 90, 179.9, 180])
def test_angles_inside_0_180_accepted(angle: float) -> None:
    assert PickConfig(filter_z_dir=["downward", angle]).filter_z_dir.angles == (float(angle),)
    assert PickConfig(filter_z_dir=["downward", 0, angle]).filter_z_dir.angles[1] == angle


@pytest.mark.parametrize(
    ("angle", "shown"),
    [
        (-1, "-1.0"),
        (180.5, "180.5"),
        (720, "720.0"),
        (math.nan, "nan"),
        (math.inf, "inf"),
        (10**400, "1000000000"),
    ],
)
def test_angles_outside_0_180_rejected(angle: float, shown: str) -> None:
    for value in (["upward", angle], ["upward", 10, angle]):
        err = error(TaskConfig, pick(filter_x_dir=value))
        assert err.key == "pick.filter_x_dir"
        assert err.message.startswith(f"angle {shown}")
        assert err.message.endswith("must be in [0, 180] degrees")


@pytest.mark.parametrize("angle", ["90", True, None, [90]])
def test_angles_must_be_numbers(angle: Any) -> None:
    err = error(TaskConfig, pick(filter_x_dir=["forward", angle]))
    assert err.message == f"angle {angle!r} must be a number of degrees"


@pytest.mark.parametrize(
    ("direction", "a1", "a2", "never"),
    [
        ("forward", 135, 45, False),
        ("forward", 45, 135, True),
        ("upward", 90, 10, False),
        ("upward", 10, 90, True),
        ("backward", 100, 170, False),
        ("backward", 170, 100, True),
        ("downward", 110, 140, False),
        ("downward", 140, 110, True),
        ("downward", 120, 120, False),
    ],
)
def test_band_ordering_rule(direction: str, a1: float, a2: float, never: bool) -> None:
    spec = PickConfig(filter_z_dir=[direction, a1, a2]).filter_z_dir
    assert spec is not None and spec.never_passes() is never
    assert AxisFilter(direction=direction, angles=(a1,)).never_passes() is False


def test_strict_semantics_rejects_a_reversed_band_and_explains_the_order() -> None:
    # Reference semantics keep the reversed band (the quirk is reproduced, not hidden).
    assert PickConfig(filter_z_dir=["downward", 140, 110]).filter_z_dir.never_passes()
    err = error(TaskConfig, pick(semantics="strict", filter_z_dir=["downward", 140, 110]))
    assert err.key == "pick.filter_z_dir"
    assert err.message == (
        "filter_z_dir ['downward', 140.0, 110.0] can never pass: backward/downward bands need the "
        "smaller angle first (angles are measured from base +X or +Z); did you mean "
        "['downward', 110.0, 140.0]?"
    )
    err = error(TaskConfig, pick(semantics="strict", approach_filter=["forward", 45, 135]))
    assert err.key == "pick.approach_filter"
    assert "forward/upward bands need the larger angle first" in err.message
    assert "did you mean ['forward', 135.0, 45.0]?" in err.message
    assert check(TaskConfig, pick(semantics="strict", facing_filter=["upward", 90, 10]))


# --------------------------------------------------------------------------------------------
# Other pick keys


def test_reference_defaults() -> None:
    config = PickConfig()
    assert (config.npy_name, config.grasp_scale, config.tcp_offset) == (
        "Aligned_grasp_sparse.npy",
        1.0,
        None,
    )
    assert (config.final_gripper_state, config.pre_grasp_offset) == (-1, 0.1)
    assert (config.gripper_change_steps, config.post_grasp_offset_min) == (40, 0.05)
    assert (config.post_grasp_offset_max, config.return_to_pregrasp, config.lift_th) == (
        0.05,
        False,
        0.0,
    )
    assert (config.test_mode, config.t_eps, config.o_eps, config.process_valid) == (
        "forward",
        1e-3,
        5e-3,
        True,
    )
    assert (config.semantics, config.timing, config.ignore_substring) == ("reference", "toppra", [])
    assert config.constraints is None and config.fixed_orientation is None
    assert config.direction_to_obj is None and config.pre_grasp_hold_vec_weight is None


@pytest.mark.parametrize("state", [1, -1])
def test_final_gripper_state_values(state: int) -> None:
    assert PickConfig(final_gripper_state=state).final_gripper_state == state


@pytest.mark.parametrize("state", [0, 2, -2, "close", None])
def test_final_gripper_state_rejects_others(state: Any) -> None:
    err = error(TaskConfig, pick(final_gripper_state=state))
    assert err.key == "pick.final_gripper_state"
    assert err.message.startswith("Input should be 1 or -1")


@pytest.mark.parametrize("mode", ["forward", "ik"])
def test_test_mode_values(mode: str) -> None:
    assert PickConfig(test_mode=mode).test_mode == mode


@pytest.mark.parametrize("mode", ["plan", "IK", "", 1])
def test_test_mode_rejects_others(mode: Any) -> None:
    err = error(TaskConfig, pick(test_mode=mode))
    assert err.key == "pick.test_mode"
    assert err.message.startswith("Input should be 'forward' or 'ik'")


def test_post_grasp_offsets_ordered() -> None:
    assert PickConfig(post_grasp_offset_min=0.1, post_grasp_offset_max=0.1)
    assert PickConfig(post_grasp_offset_min=0.05, post_grasp_offset_max=0.2)
    err = error(TaskConfig, pick(post_grasp_offset_min=0.2, post_grasp_offset_max=0.1))
    assert err.key == "pick.post_grasp_offset_max"
    assert err.message == "post_grasp_offset_min (0.2) must be <= post_grasp_offset_max (0.1)"
    # Only min given: the error names min, the key the user wrote (max is the 0.05 default).
    err = error(TaskConfig, pick(post_grasp_offset_min=0.2))
    assert err.key == "pick.post_grasp_offset_min"
    assert err.message == "post_grasp_offset_min (0.2) must be <= post_grasp_offset_max (0.05)"


@pytest.mark.parametrize("constraints", [["y", 0.2, 0.3], ["x", 0, 1], ["z", 0.5, 0.5]])
def test_constraints_accepted(constraints: list[Any]) -> None:
    assert PickConfig(constraints=constraints).constraints == tuple(constraints)


@pytest.mark.parametrize(
    ("constraints", "message"),
    [
        (
            ["y", 0.65, 0.2],
            "constraints [axis, rmin, rmax] needs rmin <= rmax, got ['y', 0.65, 0.2]",
        ),
        (["w", 0.2, 0.3], "Input should be 'x', 'y' or 'z'"),
        (["y", -0.1, 0.3], "Input should be greater than or equal to 0"),
        (["y", 0.1, 1.5], "Input should be less than or equal to 1"),
        (["y", 0.1], "too few values: item [2] is missing"),
        (["y", 0.1, 0.2, 0.3], "Tuple should have at most 3 items"),
    ],
)
def test_constraints_rejected(constraints: list[Any], message: str) -> None:
    err = error(TaskConfig, pick(constraints=constraints))
    assert err.key is not None and err.key.startswith("pick.constraints")
    assert err.message.startswith(message)


@pytest.mark.parametrize(
    "quaternion", [[1, 0, 0, 0], [0, 0, 0, 1], [0.7071068, 0.7071068, 0, 0], [0.5, 0.5, 0.5, 0.5]]
)
def test_fixed_orientation_unit_quaternion(quaternion: list[float]) -> None:
    assert PickConfig(fixed_orientation=quaternion).fixed_orientation == tuple(quaternion)


@pytest.mark.parametrize(
    ("quaternion", "message"),
    [
        ([1, 1, 0, 0], "fixed_orientation must be a unit wxyz quaternion (norm 1.414)"),
        ([0, 0, 0, 0], "fixed_orientation must be a unit wxyz quaternion (norm 0)"),
        ([1, 0, 0], "too few values: item [3] is missing"),
        ([math.nan, 0, 0, 1], "Input should be a finite number"),
    ],
)
def test_fixed_orientation_rejected(quaternion: list[float], message: str) -> None:
    err = error(TaskConfig, pick(fixed_orientation=quaternion))
    assert err.key is not None and err.key.startswith("pick.fixed_orientation")
    assert err.message.startswith(message)


@pytest.mark.parametrize(
    ("key", "value"),
    [
        ("grasp_scale", 0),
        ("tcp_offset", 0.6),
        ("pre_grasp_offset", 0.7),
        ("gripper_change_steps", 0),
        ("lift_th", -0.01),
        ("t_eps", 0),
        ("o_eps", -1),
        ("speed_scale", 1.5),
        ("hold_time", 61),
        ("max_slip", 0),
        ("direction_to_obj", "up"),
        ("semantics", "faithful"),
        ("timing", "linear"),
        ("objects", []),
        ("npy_name", ""),
        ("pre_grasp_hold_vec_weight", [1, 1, 1]),
        ("name", "place"),
        ("return_to_pregrasp", "maybe"),
    ],
)
def test_pick_value_ranges(key: str, value: Any) -> None:
    err = error(TaskConfig, pick(**{key: value}))
    assert err.key is not None and err.key.startswith(f"pick.{key}")


def test_reference_only_keys_are_accepted() -> None:
    config = PickConfig(
        name="pick",
        close_wait_steps=5,
        update_pose_cost_metric_none=True,
        constrain_grasp_approach=1,
    )
    assert config.close_wait_steps == 5


# --------------------------------------------------------------------------------------------
# Unknown keys with suggestions, at every level


@pytest.mark.parametrize(
    ("data", "key", "suggestion"),
    [
        (task(robto="fr3"), "robto", "robot"),
        (task(max_episode_lenght=3), "max_episode_lenght", "max_episode_length"),
        (pick(filter_z_dri=["downward", 140]), "pick.filter_z_dri", "filter_z_dir"),
        (pick(pre_grasp_ofset=0.1), "pick.pre_grasp_ofset", "pre_grasp_offset"),
        (task(objects=[{"name": "a", "mesh": "b", "mas": 1}]), "objects[0].mas", "mass"),
        (
            task(objects=[{"name": "a", "mesh": "b"}, {"name": "c", "mesh": "d", "frction": 1}]),
            "objects[1].frction",
            "friction",
        ),
        (task(physics={"imp_ratio": 10}), "physics.imp_ratio", "impratio"),
        (task(physics={"time_step": 0.001}), "physics.time_step", "timestep"),
        (
            task(robot_placement={"pos_range": [[0, 0, 0], [0, 0, 0]], "yaw_rang": [0, 0]}),
            "robot_placement.yaw_rang",
            "yaw_range",
        ),
        (
            task(objects=[{"name": "a", "mesh": "b", "placement": {"pos_rnge": 1}}]),
            "objects[0].placement.pos_rnge",
            "pos_range",
        ),
    ],
)
def test_unknown_keys_suggest_the_closest(data: dict[str, Any], key: str, suggestion: str) -> None:
    err = error(TaskConfig, data)
    assert err.key == key
    assert err.message == f"unknown key; did you mean {suggestion!r}?"


def test_unknown_keys_in_sweeps_and_random_axes() -> None:
    err = error(SweepConfig, {"name": "s", "tasks": ["t.yaml"], "episodes_per_pont": 3})
    assert (err.key, err.message) == (
        "episodes_per_pont",
        "unknown key; did you mean 'episodes_per_point'?",
    )
    data = {
        "name": "s",
        "tasks": ["t.yaml"],
        "mode": "random",
        "random_axes": {"pick.lift_th": {"low": 0, "hihg": 1}},
    }
    err = error(SweepConfig, data)
    assert (err.key, err.message) == (
        "random_axes.pick.lift_th.hihg",
        "unknown key; did you mean 'high'?",
    )


def test_unknown_key_without_a_close_match() -> None:
    err = error(TaskConfig, pick(zzzzzz=1))
    assert (err.key, err.message) == ("pick.zzzzzz", "unknown key")


def test_missing_required_keys() -> None:
    err = error(TaskConfig, {"objects": BASE_TASK["objects"]})
    assert (err.key, err.message) == ("robot", "required key is missing")
    err = error(TaskConfig, task(objects=[{"name": "a"}]))
    assert (err.key, err.message) == ("objects[0].mesh", "required key is missing")


def test_non_string_keys_are_named() -> None:
    err = located("robot: fr3\nobjects: [{name: a, mesh: b}]\npick:\n  1: 2\n")
    assert err.one_line() == (
        "t.yaml:4 pick: key 1 is a int, keys must be strings (quote it, or fix the name)"
    )
    err = located("robot: fr3\nobjects: [{name: a, mesh: b}]\nnull: 2\n")
    assert err.line == 3 and "key None is a NoneType" in err.message


def test_wrong_document_shapes() -> None:
    for data in (None, [1, 2], "robot", 3):
        err = error(TaskConfig, data)
        assert err.message.startswith("expected a mapping of TaskConfig keys, got ")
    err = error(TaskConfig, task(pick=[1, 2]))
    assert err.key == "pick"
    assert err.message.startswith("Input should be a valid dictionary or instance of PickConfig")


def test_long_inputs_are_shortened_in_messages() -> None:
    err = error(TaskConfig, pick(gripper_change_steps=10**400))
    assert len(err.one_line()) < 150
    assert err.message.endswith("...)")


# --------------------------------------------------------------------------------------------
# Task: placement, scale, objects, cross checks


def test_placement_ordering() -> None:
    ok = Placement(pos_range=((0, -0.1, 0), (0, 0.1, 0.05)), yaw_range=(-10, 10))
    assert ok.pos_range[1] == (0.0, 0.1, 0.05)
    assert Placement(pos_range=((0, 0, 0), (0, 0, 0))).yaw_range == (-180.0, 180.0)
    placement = {"pos_range": [[0, 0.2, 0], [0, 0.1, 0]]}
    err = error(TaskConfig, task(robot_placement=placement))
    assert (err.key, err.message) == (
        "robot_placement.pos_range",
        "pos_range axis y: min 0.2 must be <= max 0.1",
    )
    placement = {"pos_range": [[0, 0, 0], [0, 0, 0]], "yaw_range": [30, -30]}
    err = error(TaskConfig, task(objects=[{"name": "a", "mesh": "b", "placement": placement}]))
    assert (err.key, err.message) == (
        "objects[0].placement.yaw_range",
        "yaw_range min 30.0 must be <= max -30.0",
    )


@pytest.mark.parametrize(
    "pos_range", [[[0, 0, 0]], [[0, 0], [1, 1]], [[0, 0, math.nan], [0, 0, 1]], "x", None]
)
def test_placement_shapes(pos_range: Any) -> None:
    err = error(TaskConfig, task(robot_placement={"pos_range": pos_range}))
    assert err.key is not None and err.key.startswith("robot_placement.pos_range")


@pytest.mark.parametrize(
    ("scale", "expected"), [(2, (2, 2, 2)), (0.001, (0.001,) * 3), ([1, 2, 3], (1, 2, 3))]
)
def test_scale_forms(scale: Any, expected: tuple[float, ...]) -> None:
    assert ObjectConfig(name="a", mesh="b", scale=scale).scale == expected


@pytest.mark.parametrize("scale", [0, -1, [1, 0, 1], [1, 1], True, "big", [1, 1, math.inf]])
def test_scale_rejected(scale: Any) -> None:
    err = error(TaskConfig, task(objects=[{"name": "a", "mesh": "b", "scale": scale}]))
    assert err.key is not None and err.key.startswith("objects[0].scale")
    if scale in (0, -1) or scale == [1, 0, 1]:
        assert err.message.startswith("scale must be positive")


def test_object_names_unique() -> None:
    objects = [{"name": "a", "mesh": "m"}, {"name": "b", "mesh": "m"}, {"name": "a", "mesh": "n"}]
    err = error(TaskConfig, task(objects=objects))
    assert (err.key, err.message) == ("objects[2].name", "object names must be unique, 'a' repeats")


def test_pick_objects_must_name_task_objects() -> None:
    objects = [{"name": "cube", "mesh": "m"}, {"name": "ball", "mesh": "m"}]
    config = check(TaskConfig, task(objects=objects))
    assert config.pick.objects == ["cube"]  # default: the first object
    assert config.target_object.name == "cube"
    config = check(TaskConfig, task(objects=objects, pick={"objects": ["ball"]}))
    assert config.target_object.name == "ball"
    err = error(TaskConfig, task(objects=objects, pick={"objects": ["ball", "cub"]}))
    assert err.key == "pick.objects[1]"
    assert err.message == "unknown object 'cub'; did you mean 'cube'? (objects: ['cube', 'ball'])"


def test_objects_list_not_empty() -> None:
    err = error(TaskConfig, task(objects=[]))
    assert err.key == "objects"
    assert err.message.startswith("List should have at least 1 item")


def test_control_dt_at_least_timestep() -> None:
    err = error(TaskConfig, task(control_dt=0.001))
    assert (err.key, err.message) == (
        "control_dt",
        "control_dt (0.001 s) must be at least physics.timestep (0.002 s)",
    )
    err = error(TaskConfig, task(physics={"timestep": 0.04}))
    assert err.key == "physics.timestep"


def test_home_and_noise_lengths_match() -> None:
    assert check(TaskConfig, task(home=[0, 1], home_noise_std=[0.1, 0.1])).home == [0, 1]
    err = error(TaskConfig, task(home=[0, 1], home_noise_std=[0.1]))
    assert (err.key, err.message) == (
        "home_noise_std",
        "home_noise_std has 1 values but home has 2",
    )
    err = error(TaskConfig, task(home_noise_std=[-0.1]))
    assert err.key == "home_noise_std[0]"
    err = error(TaskConfig, task(home=[math.inf]))
    assert err.key == "home[0]"


@pytest.mark.parametrize(
    ("physics", "key"),
    [
        ({"gravity": [math.nan, 0, -9.81]}, "physics.gravity[0]"),
        ({"integrator": "verlet"}, "physics.integrator"),
        ({"cone": "round"}, "physics.cone"),
        ({"impratio": 0.5}, "physics.impratio"),
        ({"noslip_iterations": -1}, "physics.noslip_iterations"),
        ({"solver_iterations": 0}, "physics.solver_iterations"),
        ({"timestep": 0}, "physics.timestep"),
        ({"table_contact": "sometimes"}, "physics.table_contact"),
    ],
)
def test_physics_rules(physics: dict[str, Any], key: str) -> None:
    assert error(TaskConfig, task(physics=physics)).key == key


def test_physics_defaults_are_the_grasp_recipe() -> None:
    physics = PhysicsConfig()
    assert (physics.cone, physics.impratio, physics.timestep) == ("elliptic", 10.0, 0.002)


def test_orientations_are_finite_vec3() -> None:
    obj = {"name": "a", "mesh": "b", "orientations": [[0, 0, 0], [90, 0, 180]]}
    assert check(TaskConfig, task(objects=[obj])).objects[0].orientations[1] == (90, 0, 180)
    obj = {"name": "a", "mesh": "b", "orientations": [[0, 0, math.inf]]}
    assert error(TaskConfig, task(objects=[obj])).key == "objects[0].orientations[0][2]"


@pytest.mark.parametrize(
    ("key", "value"),
    [("arm", "middle"), ("robot", ""), ("name", ""), ("max_episode_length", 0), ("control_dt", 1)],
)
def test_task_value_rules(key: str, value: Any) -> None:
    assert error(TaskConfig, task(**{key: value})).key == key


def test_base_dir_follows_the_source(tmp_path: Path) -> None:
    path = tmp_path / "sub" / "t.yaml"
    path.parent.mkdir()
    path.write_text(yaml.safe_dump(BASE_TASK))
    assert load_task(path).base_dir() == path.parent.resolve()


# --------------------------------------------------------------------------------------------
# Sweeps


def sweep(**changes: Any) -> dict[str, Any]:
    return {"name": "s", "tasks": ["t.yaml"], **changes}


@pytest.mark.parametrize(
    "key",
    [
        "pick.filter_z_dir",
        "pick.pre_grasp_offset",
        "object.friction",
        "objects.0.mass",
        "physics.impratio",
        "robot",
        "control_dt",
    ],
)
def test_sweep_axis_keys_accepted(key: str) -> None:
    assert list(check(SweepConfig, sweep(axes={key: [1, 2]})).axes) == [key]


@pytest.mark.parametrize(
    ("key", "message"),
    [
        (
            "pick.filter_z_dri",
            "axis key 'pick.filter_z_dri': unknown pick key 'filter_z_dri'; "
            "did you mean 'filter_z_dir'?",
        ),
        (
            "pik.filter_z_dir",
            "axis key 'pik.filter_z_dir': unknown task key 'pik'; did you mean 'pick'?",
        ),
        ("zzz.qqq", "axis key 'zzz.qqq': unknown task key 'zzz'"),
        ("pick..lift_th", "axis key 'pick..lift_th' is not a dotted key like 'pick.filter_z_dir'"),
        (".lift_th", "axis key '.lift_th' is not a dotted key like 'pick.filter_z_dir'"),
    ],
)
def test_sweep_axis_keys_rejected(key: str, message: str) -> None:
    err = error(SweepConfig, sweep(axes={key: [1]}))
    assert (err.key, err.message) == (f"axes.{key}", message)
    err = error(SweepConfig, sweep(mode="random", random_axes={key: {"low": 0, "high": 1}}))
    assert (err.key, err.message) == (f"random_axes.{key}", message)


def test_sweep_axis_needs_values() -> None:
    err = error(SweepConfig, sweep(axes={"pick.lift_th": []}))
    assert (err.key, err.message) == ("axes.pick.lift_th", "axis 'pick.lift_th' has no values")


@pytest.mark.parametrize(
    "axis", [{"low": 0.0, "high": 1.0}, {"low": 1, "high": 1}, {"choices": [1, "a", [1, 2]]}]
)
def test_random_axis_forms(axis: dict[str, Any]) -> None:
    config = check(SweepConfig, sweep(mode="random", random_axes={"pick.lift_th": axis}, points=3))
    assert config.random_axes["pick.lift_th"] == RandomAxis(**axis)


@pytest.mark.parametrize(
    ("axis", "key", "message"),
    [
        ({"low": 0, "high": 1, "choices": [1]}, "", "give either low and high, or choices"),
        ({}, "", "give either low and high, or choices"),
        ({"low": 0}, "", "give either low and high, or choices"),
        ({"low": 2, "high": 1}, ".high", "low (2.0) must be <= high (1.0)"),
        ({"choices": []}, ".choices", "choices must not be empty"),
        ({"low": math.nan, "high": 1}, ".low", "Input should be a finite number (got nan)"),
    ],
)
def test_random_axis_rejected(axis: dict[str, Any], key: str, message: str) -> None:
    err = error(SweepConfig, sweep(mode="random", random_axes={"pick.lift_th": axis}))
    assert (err.key, err.message) == (f"random_axes.pick.lift_th{key}", message)


def test_sweep_mode_matches_its_axes() -> None:
    err = error(SweepConfig, sweep(mode="random"))
    assert (err.key, err.message) == ("mode", "mode 'random' needs random_axes")
    err = error(SweepConfig, sweep(random_axes={"pick.lift_th": {"low": 0, "high": 1}}))
    assert (err.key, err.message) == ("random_axes", "random_axes are only used with mode: random")


@pytest.mark.parametrize("record", ["none", "failures", "invalid", "all", "sample:1", "sample:250"])
def test_record_pattern_accepted(record: str) -> None:
    assert check(SweepConfig, sweep(record=record)).record == record


@pytest.mark.parametrize(
    "record", ["sample:", "sample:x", "sample:0", "sample:01", "some", "ALL", "failures ", ""]
)
def test_record_pattern_rejected(record: str) -> None:
    err = error(SweepConfig, sweep(record=record))
    assert err.key == "record"
    assert err.message.startswith(
        "String should match pattern '^(none|failures|invalid|all|sample:[1-9][0-9]*)$'"
    )


@pytest.mark.parametrize(
    ("key", "value"),
    [
        ("name", "has space"),
        ("name", ""),
        ("tasks", []),
        ("points", 0),
        ("episodes_per_point", 0),
        ("seed", -1),
        ("workers", 0),
        ("mode", "latin"),
    ],
)
def test_sweep_value_rules(key: str, value: Any) -> None:
    assert error(SweepConfig, sweep(**{key: value})).key == key


def test_sweep_tasks_may_be_paths_inline_or_interndata() -> None:
    tasks = ["a.yaml", BASE_TASK, {"interndata": "x.yaml", "asset_root": "/a"}]
    assert check(SweepConfig, sweep(tasks=tasks)).tasks == tasks


# --------------------------------------------------------------------------------------------
# Located errors: file:line key.path: message


LOCATED = """\
name: located
robot: fr3
objects:
  - name: cube
    mesh: cube
  - name: ball
    mesh: ball
    mass: heavy
pick:
  objects: [cube]
  filter_z_dir: [downward, 140]
"""


def test_located_error_in_a_second_list_item() -> None:
    err = located(LOCATED, path="dir/t.yaml")
    assert err.one_line() == (
        "dir/t.yaml:8 objects[1].mass: Input should be a valid number, unable to parse string "
        "as a number (got 'heavy')"
    )
    assert (err.file, err.line, err.key) == ("dir/t.yaml", 8, "objects[1].mass")


def test_located_errors_at_several_lines() -> None:
    base = LOCATED.replace("mass: heavy", "mass: 0.2")
    cases = [
        (base.replace("name: located", "nme: located"), 1, "nme"),
        (
            base.replace("    mesh: cube\n", "    mesh: cube\n    colour: red\n"),
            6,
            "objects[0].colour",
        ),
        (base.replace("[downward, 140]", "[down, 140]"), 11, "pick.filter_z_dir"),
        (base.replace("objects: [cube]", "objects: [cube, box]"), 10, "pick.objects[1]"),
        (base + "  post_grasp_offset_min: 0.3\n", 12, "pick.post_grasp_offset_min"),
        (base + "physics:\n  cone: round\n", 13, "physics.cone"),
        (base + "control_dt: 0.0001\n", 12, "control_dt"),
        (base.replace("  - name: ball", "  - name: cube"), 6, "objects[1].name"),
    ]
    for text, line, key in cases:
        err = located(text)
        assert (err.line, err.key) == (line, key), text
        assert err.one_line().startswith(f"t.yaml:{line} {key}: ")


def test_located_sweep_errors() -> None:
    text = (
        "name: s\ntasks: [a.yaml]\naxes:\n  pick.lift_th: [0.01]\n  pick.lft_th: [1]\n"
        "episodes_per_point: 0\n"
    )
    err = located(text, SweepConfig)
    assert err.one_line().startswith("t.yaml:5 axes.pick.lft_th: axis key 'pick.lft_th'")
    err = located(text.replace("  pick.lft_th: [1]\n", ""), SweepConfig)
    assert err.one_line().startswith("t.yaml:5 episodes_per_point: Input should be greater than")


def test_load_task_and_sweep_name_the_file(tmp_path: Path) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text("robot: fr3\nobjects:\n  - {name: a, mesh: b, scale: -1}\n")
    with pytest.raises(ConfigError) as info:
        load_task(path)
    assert info.value.one_line() == (
        f"{path}:3 objects[0].scale: scale must be positive, got [-1.0, -1.0, -1.0]"
    )
    path.write_text("name: s\ntasks: [a.yaml]\nseed: -3\n")
    with pytest.raises(ConfigError, match=rf"^{re.escape(str(path))}:3 seed: Input should be"):
        load_sweep(path)


def test_one_line_format_parts() -> None:
    assert ConfigError("m").one_line() == "m"
    assert ConfigError("m", key="a.b").one_line() == "a.b: m"
    assert ConfigError("m", file="f.yaml").one_line() == "f.yaml: m"
    assert ConfigError("m", file="f.yaml", line=3).one_line() == "f.yaml:3: m"
    assert ConfigError("m", file="f.yaml", line=3, key="k").one_line() == "f.yaml:3 k: m"
    assert str(ConfigError("m", file="f", line=1, key="k")) == "f:1 k: m"
    assert ConfigError("m", key="k").with_file("f.yaml").one_line() == "f.yaml k: m"
    assert ConfigError("m", file="a").with_file("b").file == "a"


# --------------------------------------------------------------------------------------------
# The example files under tasks/examples


def test_valid_examples_load() -> None:
    kinds = {path.name: load_any(path)[0] for path in sorted(EXAMPLES.glob("*.yaml"))}
    assert kinds == {
        "fr3_cube.yaml": "task",
        "split_aloha_right_neutral.yaml": "task",
        "sweep_downward.yaml": "sweep",
        "sweep_random.yaml": "sweep",
    }
    fr3 = load_task(EXAMPLES / "fr3_cube.yaml")
    assert fr3.pick.filter_x_dir == AxisFilter(direction="forward", angles=(90,))
    assert fr3.pick.filter_z_dir == AxisFilter(direction="downward", angles=(140,))
    assert (fr3.pick.test_mode, fr3.pick.post_grasp_offset_max) == ("ik", 0.2)
    grid = load_sweep(EXAMPLES / "sweep_downward.yaml")
    assert [len(v) for v in grid.axes.values()] == [3, 2]


INVALID = sorted((EXAMPLES / "invalid").glob("*.yaml"))


@pytest.mark.parametrize("path", INVALID, ids=[p.stem for p in INVALID])
def test_invalid_examples_fail_as_their_header_says(path: Path) -> None:
    """Each invalid example states its own error on line 1: ``# expect: LINE KEY: MESSAGE``."""
    header = path.read_text().splitlines()[0]
    match = re.fullmatch(r"# expect: (\d+) (.*)", header)
    assert match, f"{path} needs an '# expect: LINE KEY: MESSAGE' header"
    line, rest = match.groups()
    expected = f"{path}:{line}{rest}" if rest.startswith(":") else f"{path}:{line} {rest}"
    with pytest.raises(ConfigError) as info:
        load_any(path)
    assert info.value.one_line().startswith(expected)


def test_kind_of() -> None:
    assert kind_of(BASE_TASK) == "task"
    assert kind_of({"pick": {}}) == "task"
    assert kind_of(sweep()) == "sweep"
    assert kind_of({"tasks": [{"robots": []}]}) == "interndata"
    assert kind_of({"tasks": [{"skills": []}]}) == "interndata"
    assert kind_of({"other": 1}) == "unknown"
    assert kind_of([1]) == "unknown"


def test_load_any_rejects_unknown_documents(tmp_path: Path) -> None:
    path = tmp_path / "x.yaml"
    path.write_text("hello: world\n")
    with pytest.raises(ConfigError, match=r"x.yaml:1: not a task .* or a sweep"):
        load_any(path)


# --------------------------------------------------------------------------------------------
# Overrides (--set key=value and sweep points)


def test_apply_overrides() -> None:
    config = check(TaskConfig, task(pick={"filter_z_dir": ["downward", 140]}))
    changed = apply_overrides(
        config,
        {
            "pick.filter_z_dir": ["downward", 120],
            "object.friction": 0.5,
            "objects.0.mass": 0.3,
            "physics.impratio": 20,
        },
    )
    assert changed.pick.filter_z_dir == AxisFilter(direction="downward", angles=(120,))
    assert (changed.objects[0].friction, changed.objects[0].mass) == (0.5, 0.3)
    assert changed.physics.impratio == 20
    assert config.pick.filter_z_dir.angles == (140,)  # the original is untouched


def test_a_nested_override_keeps_the_siblings_of_its_key() -> None:
    """Issue 33 item 9: ``--set robot_placement.pos_range=...`` alone reset the robot's yaw to
    [-180, 180] (the robot then faced a random way). A nested key merges into what the task
    runs with: its own placement, else the one robot.yaml gives it."""
    pos = [[0.0, -0.5, 0.0], [0.0, -0.48, 0.0]]
    own = {"pos_range": [[0, -0.45, 0], [0, -0.45, 0]], "yaw_range": [80.0, 85.0]}
    config = check(TaskConfig, task(robot_placement=own))
    changed = apply_overrides(config, {"robot_placement.pos_range": pos})
    assert changed.robot_placement is not None
    assert changed.robot_placement.yaw_range == (80.0, 85.0)  # the task file's
    assert changed.robot_placement.pos_range == ((0.0, -0.5, 0.0), (0.0, -0.48, 0.0))
    inherited = check(TaskConfig, task())  # no robot_placement: robot.yaml's (fr3: yaw 90)
    assert inherited.robot_placement is None
    changed = apply_overrides(inherited, {"robot_placement.pos_range": pos})
    assert changed.robot_placement is not None and changed.robot_placement.yaw_range == (90, 90)
    region = {"pos_range": [[0.1, 0.0, 0.0], [0.2, 0.1, 0.0]], "yaw_range": [10.0, 20.0]}
    config = check(TaskConfig, task(objects=[{"name": "a", "mesh": "b", "placement": region}]))
    changed = apply_overrides(config, {"object.placement.pos_range": [[0, 0, 0], [0, 0, 0]]})
    assert changed.objects[0].placement is not None
    assert changed.objects[0].placement.yaw_range == (10.0, 20.0)


def test_override_values_nested_too_deep_are_refused() -> None:
    config = check(TaskConfig, task())
    with pytest.raises(ConfigError, match="nests more than 32 levels"):
        apply_overrides(
            config,
            {"pick.lift_th": [[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[0]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]},
        )
    with pytest.raises(ValueError, match="nests more than 32 levels"):
        parse_set_value("[" * 5000 + "]" * 5000)


def test_apply_overrides_errors_name_the_key() -> None:
    config = check(TaskConfig, task(source="dir/t.yaml"))
    with pytest.raises(ConfigError) as info:
        apply_overrides(config, {"pick.lift_thh": 0.1})
    assert info.value.key == "pick.lift_thh"
    assert "did you mean 'lift_th'" in info.value.message
    assert info.value.file == "dir/t.yaml"
    with pytest.raises(ConfigError) as info:
        apply_overrides(config, {"pick.lift_th": -1})
    assert (info.value.key, info.value.file) == ("pick.lift_th", "dir/t.yaml")
    with pytest.raises(ConfigError):
        apply_overrides(config, {"objects.5.mass": 1})


def test_set_dotted_and_parse_set_value() -> None:
    data: dict[str, Any] = {"objects": [{"mass": 1}]}
    set_dotted(data, "object.mass", 2)
    set_dotted(data, "pick.filter_z_dir", ["downward", 150])
    assert data == {"objects": [{"mass": 2}], "pick": {"filter_z_dir": ["downward", 150]}}
    assert parse_set_value("[downward, 140]") == ["downward", 140]
    assert parse_set_value("0.05") == 0.05
    assert parse_set_value("[unclosed") == "[unclosed"


# --------------------------------------------------------------------------------------------
# Docs list every key


@pytest.mark.parametrize(
    "model",
    [TaskConfig, PickConfig, ObjectConfig, PhysicsConfig, Placement, SweepConfig, RandomAxis],
)
def test_docs_describe_every_key(model: type) -> None:
    text = DOCS.read_text()
    missing = [name for name in model.model_fields if f"`{name}`" not in text]
    assert not missing, f"docs/config.md does not describe {model.__name__} keys {missing}"


# --------------------------------------------------------------------------------------------
# Property tests: accept or ConfigError, never anything else

TEXT = st.text(st.characters(exclude_categories=("Cs",)), max_size=12)
WEIRD_STRINGS = st.sampled_from(
    ["", " ", "forward", "downward", "nan", "1e400", "${x}", "~", "null", "yes", "0x1F", "\u202e"]
)
SCALARS = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(10**30), max_value=10**30),
    st.sampled_from([10**400, -(10**400), 2**63, -(2**63) - 1]),
    st.floats(allow_nan=True, allow_infinity=True),
    TEXT,
    WEIRD_STRINGS,
)
VALUES = st.recursive(
    SCALARS,
    lambda children: st.one_of(
        st.lists(children, max_size=5),
        st.dictionaries(st.one_of(TEXT, st.integers(), st.none()), children, max_size=5),
    ),
    max_leaves=20,
)
# Values near the valid ones hit deeper validators than pure noise does.
PLAUSIBLE = st.one_of(
    st.tuples(st.sampled_from([*DIRECTIONS, "leftward"]), st.floats(-10, 200)).map(list),
    st.tuples(st.sampled_from(DIRECTIONS), st.floats(-10, 200), st.floats(-10, 200)).map(list),
    st.lists(st.floats(-2, 2), min_size=2, max_size=5),
    st.tuples(st.sampled_from(["x", "y", "z", "w"]), st.floats(-1, 2), st.floats(-1, 2)).map(list),
    st.sampled_from([-1, 0, 1, 0.05, 0.2, 140, "ik", "forward", "strict", "reference"]),
)
ANY_VALUE = st.one_of(VALUES, PLAUSIBLE)

# ``pytest --hypothesis-profile=bughunt`` (tests/conftest.py) runs a longer bug hunt; 150 keeps
# the suite fast.
FUZZ = settings(
    max_examples=max(150, settings.default.max_examples),
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
    database=None,
)
FUZZ_DIR = Path(tempfile.mkdtemp(prefix="harness-config-fuzz-"))
atexit.register(shutil.rmtree, FUZZ_DIR, True)


def dump(data: Any) -> str:
    return yaml.safe_dump(data, allow_unicode=True, sort_keys=False)


def loads_or_config_error(load: Any, *args: Any) -> None:
    try:
        load(*args)
    except ConfigError as exc:
        assert exc.one_line() and "\n" not in exc.one_line()


@FUZZ
@given(VALUES)
def test_random_documents_accept_or_config_error(data: Any) -> None:
    text = dump(data)
    for model in (TaskConfig, SweepConfig, PickConfig, ObjectConfig, PhysicsConfig):
        loads_or_config_error(lambda t, m=model: validate_model(m, parse_text(t, "f").data), text)


@FUZZ
@given(st.text(max_size=200))
def test_random_text_accept_or_config_error(text: str) -> None:
    def load(t: str) -> None:
        doc = parse_text(t, "f.yaml")
        validate_model(TaskConfig, doc.data, doc)
        validate_model(SweepConfig, doc.data, doc)

    loads_or_config_error(load, text)


TASK_KEYS = sorted(TaskConfig.model_fields)
PICK_KEYS = sorted(PickConfig.model_fields)
OBJECT_KEYS = sorted(ObjectConfig.model_fields)
PHYSICS_KEYS = sorted(PhysicsConfig.model_fields)
SWEEP_KEYS = sorted(SweepConfig.model_fields)


@FUZZ
@given(
    st.sampled_from(["task", "pick", "object", "physics", "placement"]),
    st.data(),
    st.lists(ANY_VALUE, min_size=1, max_size=3),
)
def test_random_values_for_each_task_key(section: str, data: st.DataObject, values: list) -> None:
    keys = {
        "task": TASK_KEYS,
        "pick": PICK_KEYS,
        "object": OBJECT_KEYS,
        "physics": PHYSICS_KEYS,
        "placement": ["pos_range", "yaw_range"],
    }[section]
    document: dict[str, Any] = {
        "robot": "fr3",
        "objects": [{"name": "cube", "mesh": "cube"}],
        "pick": {"filter_z_dir": ["downward", 140]},
    }
    target = {
        "task": document,
        "pick": document["pick"],
        "object": document["objects"][0],
        "physics": document.setdefault("physics", {}),
        "placement": document["objects"][0].setdefault(
            "placement", {"pos_range": [[0, 0, 0], [0.1, 0.1, 0]]}
        ),
    }[section]
    for value in values:
        target[data.draw(st.sampled_from(keys))] = value
    path = FUZZ_DIR / "task.yaml"
    path.write_text(dump(document), encoding="utf-8")
    loads_or_config_error(load_task, path)
    loads_or_config_error(load_any, path)


@FUZZ
@given(st.data(), st.lists(ANY_VALUE, min_size=1, max_size=3))
def test_random_values_for_each_sweep_key(data: st.DataObject, values: list) -> None:
    document: dict[str, Any] = {
        "name": "s",
        "tasks": ["t.yaml"],
        "axes": {"pick.lift_th": [0.01, 0.02]},
    }
    for value in values:
        key = data.draw(st.sampled_from([*SWEEP_KEYS, "axes.key", "random_axes.key"]))
        if key.endswith(".key"):
            head = key.split(".")[0]
            axis = data.draw(st.one_of(TEXT, st.sampled_from(["pick.lift_th", "object.mass"])))
            document.setdefault(head, {})
            if isinstance(document[head], dict):
                document[head][axis] = value
        else:
            document[key] = value
    path = FUZZ_DIR / "sweep.yaml"
    path.write_text(dump(document), encoding="utf-8")
    loads_or_config_error(load_sweep, path)
    loads_or_config_error(load_any, path)


@FUZZ
@given(st.binary(max_size=200))
def test_random_bytes_in_a_file(raw: bytes) -> None:
    path = FUZZ_DIR / "raw.yaml"
    path.write_bytes(raw)
    loads_or_config_error(load_any, path)
