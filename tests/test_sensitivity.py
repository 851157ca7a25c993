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
