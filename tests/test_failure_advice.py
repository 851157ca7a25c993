"""Every failure group's advice names the physical cause and one action (issue 56: "fix the main
failure, plan_failed at plan:lift" where the rows say the Piper's J5 is at its +70 degree limit).

The rows are shaped as the episodes write them (``limit_joint`` ``name:upper``, the object's
distance, the slip); the joint's limit comes from the robot's own URDF.
"""

from __future__ import annotations

import pandas as pd

from harness.report.advice import failure_advice, validity_advice
from harness.report.findings import findings


def arm_rows(failures: int, successes: int, **failed: object) -> pd.DataFrame:
    """One robot arm's episodes: ``failures`` plan_failed at the lift with ``failed``'s
    columns, ``successes`` nearer the arm base."""
    base = {"robot": "split_aloha", "arm": "left", "object": "banana", "semantics": "reference"}
    rows = [
        {**base, "episode_id": f"f{i}", "success": False, "failure_reason": "plan_failed",
         "failure_stage": "plan:lift", "object_distance_m": 0.55 + 0.01 * i,
         "ik_residual_mm": 40.0, "limit_joint": "left_joint5:upper", **failed}
        for i in range(failures)
    ] + [
        {**base, "episode_id": f"s{i}", "success": True, "failure_reason": "",
         "failure_stage": "", "object_distance_m": 0.35 + 0.01 * i, "limit_joint": ""}
        for i in range(successes)
    ]  # fmt: skip
    return pd.DataFrame(rows)


def test_a_lift_out_of_reach_names_the_joint_its_limit_and_where_the_objects_lie() -> None:
    group = arm_rows(8, 12)
    failed = group[~group["success"]]
    advice = failure_advice("split_aloha", "plan_failed", "plan:lift", failed, group)
    assert "split_aloha left_joint5 at its upper limit (+70 deg) in 8 of 8" in advice.cause
    assert "objects a median 0.59 m from the arm base (successes 0.40 m)" in advice.cause
    assert advice.action.startswith("place the objects nearer the arm base")


def test_at_the_successes_distance_the_action_turns_the_grasp_directions() -> None:
    group = arm_rows(6, 6)
    group["object_distance_m"] = 0.4
    advice = failure_advice(
        "split_aloha", "plan_failed", "plan:lift", group[~group["success"]], group
    )
    assert advice.action.startswith("narrow approach_filter")


def test_the_summary_finding_carries_the_cause_not_only_the_symptom() -> None:
    group = arm_rows(8, 12)
    (finding,) = [f for f in findings(group, pd.DataFrame()) if f.subject.startswith("split")]
    assert finding.change.startswith("plan_failed at plan:lift: out of reach: split_aloha left_j")
    assert "left_joint5 at its upper limit (+70 deg)" in finding.change
    assert "fix the main failure" not in finding.change


def test_slips_and_drops_say_how_far_and_what_to_raise() -> None:
    group = arm_rows(4, 4, failure_reason="dropped", failure_stage="execute:move:lift",
                     limit_joint="", slip_m=0.012, min_finger_force_n=0.8)  # fmt: skip
    failed = group[~group["success"]]
    advice = failure_advice("split_aloha", "dropped", "execute:move:lift", failed, group)
    assert advice.cause == "the object slips 12 mm in the grip, weakest finger 0.8 N"
    assert advice.action.startswith("raise the grip force (gripper.force)")
    held = pd.DataFrame({"hold_slip_m": [0.006, 0.008], "hold_rotation_rad": [0.1, 0.3]})
    slipped = validity_advice("slipped_in_hold", held)
    assert slipped is not None and "(median 7.0 mm and 0.20 rad)" in slipped.cause
