"""Failure messages grouped by their normalised pattern (issue 14), on messages copied verbatim
from rows of real runs (the demo sweep and earlier Split ALOHA / Lift-2 runs)."""

from __future__ import annotations

import pandas as pd

from harness.report.failure_groups import GROUP_COLUMNS, group_failures, normalise_message

# (robot, arm, failure_reason, error_message) of real failed rows.
REAL = [
    ("split_aloha", "left", "plan_failed", "approach: collision at 6/6 (left_link6/cube, left_link6/cube)"),  # noqa: E501
    ("split_aloha", "left", "plan_failed", "approach: collision at 4/5 (left_link6/banana)"),
    ("split_aloha", "left", "plan_failed", "approach: collision at 5/6 (left_link6/banana, left_link6/banana)"),  # noqa: E501
    ("split_aloha", "left", "plan_failed", "approach: collision at 6/6 (left_link6/banana, left_link6/banana, left_link6/banana)"),  # noqa: E501
    ("split_aloha", "left", "plan_failed", "ik_pregrasp: IK residual 56.8 mm / 0.023 rad after 99 iterations, 1 restarts"),  # noqa: E501
    ("split_aloha", "left", "plan_failed", "ik_pregrasp: IK residual 46.3 mm / 0.016 rad after 83 iterations, 1 restarts"),  # noqa: E501
    ("split_aloha", "left", "plan_failed", "ik_pregrasp: IK residual 144.1 mm / 0.058 rad after 80 iterations, 1 restarts"),  # noqa: E501
    ("split_aloha", "right", "plan_failed", "approach: collision at 5/6 (world/right_link7, world/right_link7, world/right_link7, world/right_link7, world/right_link7)"),  # noqa: E501
    ("split_aloha", "right", "dropped", "finger forces 0.00 / 0.00 N after the hold, below 0.5 N"),
    ("lift2", "left", "plan_failed", "lift: joint jump at 15/19 of the line (IK branch change)"),
    ("lift2", "left", "plan_failed", "lift: joint jump at 8/8 of the line (IK branch change)"),
    ("lift2", "left", "plan_failed", "lift: IK failed at 7/7 of the line (6.6 mm, 0.023 rad)"),
    ("lift2", "left", "collision", "robot collided: t=1.530s world/right_link7, world/right_link7, world/left_link8, world/right_link7"),  # noqa: E501
    ("lift2", "left", "timeout", "simulated-step budget of 3,000 steps reached (2,999 used, 17 more asked); raise limits.sim_steps or use a larger physics.timestep"),  # noqa: E501
    ("fr3", "left", "", ""),
]  # fmt: skip


def frame() -> pd.DataFrame:
    rows = [
        {"episode_id": f"ep{k:02d}", "robot": r, "arm": a, "failure_reason": f, "error_message": m,
         "success": f == ""}
        for k, (r, a, f, m) in enumerate(REAL)
    ]  # fmt: skip
    return pd.DataFrame(rows)


def test_collision_pairs_are_deduplicated_and_sorted() -> None:
    assert (
        normalise_message(REAL[3][3]) == normalise_message(REAL[2][3])
        and normalise_message(REAL[3][3]) == "approach: collision at #/# (left_link6/banana)"
    )
    assert normalise_message(REAL[12][3]) == (
        "robot collided: t=#s world/left_link8, world/right_link7"
    )
    # A body name's digits are part of the name, never a number.
    assert "right_link7" in normalise_message(REAL[7][3])


def test_numbers_are_replaced_and_millimetres_bucketed() -> None:
    near, near_too, far = (normalise_message(REAL[k][3]) for k in (4, 5, 6))
    assert (
        near
        == near_too
        == ("ik_pregrasp: IK residual 10-100 mm / # rad after # iterations, # restarts")
    )
    assert far == "ik_pregrasp: IK residual 100-1000 mm / # rad after # iterations, # restarts"
    assert normalise_message(REAL[13][3]).startswith(
        "simulated-step budget of # steps reached (# used, # more asked)"
    )
    assert normalise_message(REAL[11][3]) == "lift: IK failed at #/# of the line (1-10 mm, # rad)"


def test_group_failures_counts_per_robot_arm_reason_and_pattern() -> None:
    table = group_failures(frame(), examples=2)
    assert tuple(table.columns) == GROUP_COLUMNS
    assert table["count"].sum() == sum(1 for row in REAL if row[2])  # every failure, once
    assert "" not in set(table["failure_reason"])  # successes are not failures
    collisions = table[
        (table["robot"] == "split_aloha")
        & (table["arm"] == "left")
        & (table["message_pattern"] == "approach: collision at #/# (left_link6/banana)")
    ]
    assert collisions["count"].tolist() == [3]
    assert collisions["example_episode_ids"].tolist() == [["ep01", "ep02"]]
    jumps = table[table["message_pattern"].str.startswith("lift: joint jump")]
    assert jumps["count"].tolist() == [2] and jumps["robot"].tolist() == ["lift2"]
    # Sorted by robot, arm, then the most frequent first.
    keys = list(zip(table["robot"], table["arm"], -table["count"], strict=True))
    assert keys == sorted(keys)


def test_group_failures_of_a_run_without_failures_is_empty() -> None:
    table = group_failures(frame().iloc[-1:])
    assert table.empty and tuple(table.columns) == GROUP_COLUMNS
