"""The sensitivity section of a sweep over an unsourced value (harness.report.sensitivity)."""

from __future__ import annotations

import pandas as pd

from harness.report.sensitivity import (
    FLIP,
    MOVES,
    STABLE,
    sensitivity_axes,
    sensitivity_tables,
    unknown_axes,
)

FORCE = "param.gripper.force_limit"
CONE = "param.pick.approach_filter"


def summary(cells: dict[tuple[float, str], tuple[int, int]], n: int = 40) -> pd.DataFrame:
    """A summary of one arm and object: per (force, cone) the reference and valid successes."""
    rows = []
    for point_id, ((force, cone), (successes, valid)) in enumerate(cells.items()):
        rows.append(
            {
                "task": "t", "robot": "split_aloha", "arm": "right", "object": "cube",
                "point": f"{force}-{cone}", "point_id": point_id, FORCE: force, CONE: cone,
                "n": n, "successes": successes, "n_judged": n, "valid": valid,
            }
        )  # fmt: skip
    return pd.DataFrame(rows)


def test_the_unknowns_come_from_the_robot_sources() -> None:
    axes = unknown_axes()
    # Piper grip force and pad friction are "chosen" in robots/split_aloha/robot.yaml sources;
    # the Split ALOHA mounting height is swept through the robot placement.
    assert {"robot.gripper.force_limit", "robot.gripper.pad_friction"} <= axes
    assert "robot_placement.pos_range" in axes
    assert "pick.approach_filter" not in axes


def test_a_best_setting_that_changes_over_the_range_is_labelled_a_flip() -> None:
    frame = summary(
        {
            (20.0, '["downward", 140]'): (30, 10),
            (20.0, '["downward", 160]'): (12, 5),
            (80.0, '["downward", 140]'): (12, 10),
            (80.0, '["downward", 160]'): (32, 30),
        }
    )
    assert sensitivity_axes(frame) == [FORCE]
    (table,) = sensitivity_tables(frame)
    assert table.header[-3:] == ["gripper.force_limit=20", "gripper.force_limit=80", "answer"]
    assert [row[-1] for row in table.rows] == [FLIP, FLIP]
    assert table.rows[0][4] == "30/40 · valid 10/40"


def test_a_rate_that_moves_and_one_that_does_not() -> None:
    frame = summary({(20.0, "a"): (5, 2), (40.0, "a"): (20, 15), (80.0, "a"): (35, 30)})
    frame = frame.drop(columns=[CONE])
    (table,) = sensitivity_tables(frame)
    assert table.rows[0][3] == "–" and table.rows[0][-1] == MOVES
    steady = summary({(20.0, "a"): (20, 10), (80.0, "a"): (22, 11)}).drop(columns=[CONE])
    (table,) = sensitivity_tables(steady)
    assert table.rows[0][-1] == STABLE


def test_no_table_without_an_unknown_axis() -> None:
    frame = summary({(20.0, "a"): (20, 10), (20.0, "b"): (22, 11)})
    assert sensitivity_tables(frame) == []


def test_a_whole_placement_block_is_an_unknown_axis() -> None:
    frame = summary({(20.0, "a"): (20, 10), (20.0, "b"): (22, 11)}).drop(columns=[FORCE])
    frame["param.robot_placement"] = ['{"pos_range": 1}', '{"pos_range": 2}']
    frame = frame.drop(columns=[CONE])
    assert sensitivity_axes(frame) == ["param.robot_placement"]
    (table,) = sensitivity_tables(frame)
    assert table.title.startswith("Sensitivity to robot_placement")


# --------------------------------------------------------------------------------------------
# harness sensitivity: every chosen value has a sweep (harness.runs.sensitivity)


def test_every_chosen_value_of_every_robot_and_task_default_has_a_sweep(tmp_path) -> None:
    from harness.config.robot_registry import available_robots
    from harness.robots.facts import robot_file
    from harness.runs.sensitivity import TASK_DEFAULTS, plan

    handover = tmp_path / "handover.yaml"
    values, uncovered = plan(handover=handover)
    assert uncovered == []
    swept = {(v.robot, v.key) for v in values}
    for name in available_robots():
        for source, key in robot_file(name).unsourced().items():
            assert key, f"{name} {source}: a chosen value names no sweep key"
            expected = "robot_placement" if key == "robot_placement.pos_range" else key
            assert (name, expected) in swept, (name, source)
    assert {("", d.key) for d in TASK_DEFAULTS} <= swept
    # without a handover file the release rule is the one uncovered value, and says why
    _, missing = plan()
    assert missing == ["task: pick.max_first_gripper_force (needs --handover FILE)"]


def test_the_values_swept_are_half_and_twice_or_the_plausible_range() -> None:
    from harness.runs.sensitivity import default_examples, plan

    values, _ = plan(["lift2", "split_aloha"], default_examples())
    by = {(v.robot, v.key, v.suffix): v for v in values}
    torsion = by[("lift2", "robot.gripper.pad_torsion", "")]
    assert torsion.default == 0.00309 and torsion.values == (0.001545, 0.00618)
    force = by[("lift2", "robot.gripper.force_limit", "")]  # the ideal 85.7 N is the most
    assert force.values == (42.85, 58.0)
    lift = by[("lift2", "robot.timing.lift_jerk_scale", "")]
    assert lift.default == 1.0 and lift.values == (0.5, 2.0)
    mount = by[("split_aloha", "robot_placement", "")]
    low, high = (v["pos_range"] for v in mount.values)
    base = mount.default["pos_range"]
    assert abs(low[0][2] - (base[0][2] - 0.05)) < 1e-12
    assert abs(high[1][2] - (base[1][2] + 0.05)) < 1e-12
    bottle = by.get(("split_aloha", "robot.gripper.force_limit", "-bottle"))
    if bottle is not None:  # the shared examples are there
        assert bottle.values == (20.0, 80.0)


def test_the_timing_factors_scale_the_chosen_limits_of_a_real_robot() -> None:
    from helpers import PROJECT_ROOT

    import harness
    from harness.planning.chain_timing import task_timing_limits
    from harness.robots import RobotModel

    task = harness.load_task(
        PROJECT_ROOT / "tasks" / "pick" / "lift2_left.yaml",
        {"robot.timing.acceleration_scale": 0.5, "robot.timing.lift_jerk_scale": 2.0},
    )
    robot = RobotModel.load(task.robot, task.gripper)
    names = ["lift_joint", *robot.arm("left").joints]
    plain = task_timing_limits(robot, names, harness.load_task(task.source or ""))
    scaled = task_timing_limits(robot, names, task)
    assert scaled.acceleration[0] == plain.acceleration[0]  # the lift's own key
    assert list(scaled.acceleration[1:]) == [a / 2 for a in plain.acceleration[1:]]
    assert scaled.jerk is not None and plain.jerk is not None
    assert scaled.jerk[0] == 2 * plain.jerk[0] and list(scaled.jerk[1:]) == list(plain.jerk[1:])


def _rows(valid: dict[tuple[str, str], int], n: int = 20) -> pd.DataFrame:
    """Episode rows of one arm: per (value, cone) ``valid`` of ``n`` valid."""
    rows = []
    for (value, cone), k in valid.items():
        for i in range(n):
            rows.append(
                {"robot": "r", "arm": "left", "object": "cube", "failure_reason": "",
                 "valid": i < k, "param.robot.gripper.kv": float(value), CONE: cone}
            )  # fmt: skip
    return pd.DataFrame(rows)


def test_the_value_table_labels_a_flip_and_a_move() -> None:
    from harness.report.sensitivity_values import value_rows

    a, b = '["downward", 140]', '["downward", 120]'
    base = _rows({(15, a): 15, (15, b): 5})
    swept = _rows({(7.5, a): 14, (7.5, b): 4, (30, a): 2, (30, b): 19})
    (row,) = value_rows("kv", "robot.gripper.kv", 15.0, (7.5, 30.0), swept, base)
    assert row[2:5] == ["14/20", "15/20", "2/20"]
    assert row[-1] == FLIP and row[-2] == "downward 140 / downward 140 / downward 120"
    swept = _rows({(7.5, a): 14, (7.5, b): 4, (30, a): 2, (30, b): 1})
    (row,) = value_rows("kv", "robot.gripper.kv", 15.0, (7.5, 30.0), swept, base)
    assert row[-1] == MOVES and row[-2] == "downward 140"
    swept = _rows({(7.5, a): 14, (7.5, b): 4, (30, a): 16, (30, b): 6})
    (row,) = value_rows("kv", "robot.gripper.kv", 15.0, (7.5, 30.0), swept, base)
    assert row[-1] == STABLE
