"""What limits an unreachable target (``reach_limit``, harness.planning.reach) on real
episodes: a Lift-2 failure with no joint at a limit is the R5a stretched out towards a target
beyond it; one at a limit says so."""

from __future__ import annotations

import pytest
from helpers import PROJECT_ROOT

import harness

LIFT2_LEFT = PROJECT_ROOT / "tasks" / "pick" / "lift2_left.yaml"
LIFT2_RIGHT = PROJECT_ROOT / "tasks" / "pick" / "lift2_right.yaml"
# tasks/sweeps canonical Lift-2 tasks on the cube, sweep seed 424242 (20 per point): row seeds
# of plan_failed episodes. Left 247337002236653889: the lift, 34.9 mm short, no joint at a
# limit; right 224235902539104603: the lift, J4 at its lower limit.
STRETCHED_SEED = 247337002236653889
J4_LIMIT_SEED = 224235902539104603


@pytest.mark.slow
def test_a_lift2_lift_with_no_joint_at_a_limit_is_beyond_the_arms_reach() -> None:
    row = harness.run_episode(
        harness.load_task(LIFT2_LEFT, {"object.mesh": "cube"}), STRETCHED_SEED
    ).row
    assert row["failure_reason"] == "plan_failed"
    assert row["failure_stage"] == "plan:lift"
    assert row["limit_joint"] == ""
    assert row["ik_residual_mm"] > 5.0
    assert row["reach_limit"] == "beyond_reach"


@pytest.mark.slow
def test_a_lift2_lift_at_a_joint_limit_says_so() -> None:
    row = harness.run_episode(
        harness.load_task(LIFT2_RIGHT, {"object.mesh": "cube"}), J4_LIMIT_SEED
    ).row
    assert row["failure_reason"] == "plan_failed"
    assert row["limit_joint"] == "right_joint4:lower"
    assert row["reach_limit"] == "joint_limit"
