"""Pick skill: the reference command list, progress (t_eps / o_eps, idle pop), and the verdicts."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from helpers import make_task, write_box

from harness.config import PickConfig
from harness.episode import EpisodeSpec, run_episode
from harness.pick.commands import IDLE_POP_STEPS, build_commands, pose_reached
from harness.pick.executor import SERVO_CHUNK_S
from harness.pick.outcome import PickOutcome
from harness.pick.semantics import REFERENCE_IGNORE_SUBSTRINGS, STRICT_TABLE_CLEARANCE, Semantics
from harness.pick.verdict import closing_terms, first_failure, reference_terms
from harness.transforms import quat_to_matrix

CENTRE = {"placement": {"pos_range": [[0.05, 0.0, 0.0], [0.05, 0.0, 0.0]]}}


@pytest.fixture(scope="module")
def cube(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_box(tmp_path_factory.mktemp("pick_cube"), (0.04, 0.04, 0.04), "cube")


@pytest.fixture(scope="module")
def cache() -> dict:
    return {}


def run(task, seed: int = 0, cache: dict | None = None):
    return run_episode(EpisodeSpec(task=task, seed=seed), cache)


# --------------------------------------------------------------------------------------------
# Semantics and verdict terms (no simulation)


def test_semantics_policy_reference_and_strict(cube: Path) -> None:
    """Every reference-vs-strict decision resolved once from the pick (docs/semantics.md)."""
    task = make_task("fr3", "left", cube, pick={"ignore_substring": ["shelf"]})
    reference = Semantics.from_pick(task.pick)
    # the reference's forward test plans only the pre-grasp and the grasp (pick.py)
    assert not reference.test_carry and reference.fall_back_to_last_tested
    assert not (reference.fixed_orientation_in_test or reference.pregrasp_along_fixed_axis)
    assert not (reference.check_collisions or reference.check_closing_forces)
    assert not reference.hold_after_list
    world = reference.planning_world("cube")
    # the target is out for the grasp, attached for the lift; only the planned arm counts
    assert world.target == "cube" and not world.check_target and world.hold_lift
    assert world.attach_target and not world.whole_robot
    # The reference planner never sees the table, physical or not (issue 16, item 1) ...
    assert not world.check_table
    # (the rule takes no physics setting: tests/test_planning_world.py checks a scene with the
    # table physical)
    # ... and leaves out every name its controllers ignore, plus the pick's own list.
    assert world.table_clearance == 0.0
    assert world.ignore_substring == (*REFERENCE_IGNORE_SUBSTRINGS, "shelf")
    assert "table" in world.ignore_substring and "scene" in world.ignore_substring
    strict = Semantics.from_pick(PickConfig(semantics="strict", ignore_substring=["shelf"]))
    assert strict.test_carry and not strict.fall_back_to_last_tested
    assert strict.fixed_orientation_in_test and strict.pregrasp_along_fixed_axis
    assert strict.check_collisions and strict.check_closing_forces and strict.hold_after_list
    world = strict.planning_world("cube")
    assert world.check_table and world.table_clearance == STRICT_TABLE_CLEARANCE
    assert world.ignore_substring == ()


def test_verdict_terms_first_failure_wins() -> None:
    """Named terms in pipeline order; the first one that did not pass decides the reason."""
    pick = PickConfig(lift_th=0.02)
    out = PickOutcome(
        verdict_forces=(0.0, 0.0), verdict_joint_speed=9.0, verdict_object_speed=0.0,
        lift_height_m=0.0, contact_during_close=True,
    )  # fmt: skip
    terms = reference_terms(pick, out)
    assert [t.name for t in terms] == ["finger_touches_object", "velocity_valid", "lifted"]
    assert [t.passed for t in terms] == [False, False, False]
    failed = first_failure(terms)
    assert failed is not None and failed.reason == "dropped"
    out.verdict_forces, out.lift_height_m = (1.0, 0.0), 0.05
    failed = first_failure(reference_terms(pick, out))
    assert failed is not None and failed.reason == "velocity_invalid"
    out.verdict_joint_speed = 1.0
    assert first_failure(reference_terms(pick, out)) is None
    (closing,) = closing_terms(PickConfig(min_finger_force=0.5), (0.6, 0.4))
    assert closing.reason == "no_contact" and not closing.passed


# --------------------------------------------------------------------------------------------
# Command list


def test_reference_command_list_in_order() -> None:
    pick = PickConfig(gripper_change_steps=10)
    commands = build_commands(pick, lift_offset=0.1)
    numbers = [c.number for c in commands]
    assert numbers == [1, 2, 3, 5, *[6] * 10, 7, 8, 9]
    assert [c.target for c in commands[:4]] == ["current", "current", "pregrasp", "grasp"]
    assert {c.function for c in commands if c.number == 6} == {"close_gripper"}
    assert commands[-1].target == "lift" and commands[-1].gripper == "close"
    attach = [c for c in commands if c.number == 8]
    assert attach[0].event == "attach" and attach[0].function == "attach_obj"


def test_optional_commands() -> None:
    pick = PickConfig(
        gripper_change_steps=3,
        pre_grasp_hold_vec_weight=(1, 1, 1, 0, 0, 0),
        return_to_pregrasp=True,
        final_gripper_state=1,
    )
    commands = build_commands(pick, lift_offset=0.0)
    numbers = [c.number for c in commands]
    assert numbers == [1, 2, 3, 4, 5, 6, 6, 6, 7, 8, 10]  # no lift: the sampled offset is 0
    assert {c.function for c in commands if c.number == 6} == {"open_gripper"}
    assert commands[-1].target == "pregrasp" and commands[-1].gripper == "open"


# --------------------------------------------------------------------------------------------
# is_done pose test


def test_pose_reached_is_the_reference_is_subtask_done() -> None:
    """``|p - p*| < t_eps`` and ``2 acos(min(|q . q*|, 1)) < o_eps``, both strict; the q / -q
    sign does not matter. Checked against the formula on random rotations."""
    rng = np.random.default_rng(0)
    for _ in range(200):
        q_a, q_b = rng.normal(size=(2, 4))
        q_a /= np.linalg.norm(q_a)
        q_b = q_a + 0.01 * rng.normal(size=4)
        q_b /= np.linalg.norm(q_b)
        angle = 2.0 * math.acos(min(abs(float(np.dot(q_a, q_b))), 1.0))
        T_a, T_b = np.eye(4), np.eye(4)
        T_a[:3, :3], T_b[:3, :3] = quat_to_matrix(q_a), quat_to_matrix(-q_b)
        T_b[:3, 3] = [0.004, 0.0, 0.0]
        for o_eps in (0.5 * angle, 2.0 * angle):
            assert pose_reached(T_a, T_b, 0.005, o_eps) == (angle < o_eps)
        assert not pose_reached(T_a, T_b, 0.004, 1.0)  # |p - p*| = t_eps is not reached


# --------------------------------------------------------------------------------------------
# Execution


def test_reference_pick_sequence_and_closing_quirk(cube: Path, cache: dict) -> None:
    """A successful FR3 pick: the segments run in order; closing starts as soon as the EE is
    within t_eps (1 cm) of the grasp, before the approach has ended (reference quirk 8); the
    close commands take at least gripper_change_steps control steps; the verdict comes the step
    the list empties, with the EE within t_eps of the lift target."""
    task = make_task("fr3", "left", cube, object=CENTRE)
    result = run(task, 0, cache)
    assert result.success, result.row["error_message"]
    trace = result.trace
    times = {text.split(" (")[0].split(",")[0]: t for t, text in trace.events}
    assert times["segment transport"] < times["segment approach"] < times["segment lift"]
    assert times["gripper close"] < times["approach done"]
    closed = next(t for t, text in trace.events if text.startswith("closed"))
    control_dt = round(task.control_dt / 0.002) * 0.002
    assert closed - times["gripper close"] >= (task.pick.gripper_change_steps - 1) * control_dt
    end = trace.ee_pose[-1, :3]
    assert np.linalg.norm(end - trace.T_world_lift[:3, 3]) < task.pick.t_eps
    # The object was really lifted, and it is held by friction (never welded).
    assert trace.object_pose[-1, 2] - trace.object_pose[0, 2] > task.pick.lift_th
    assert result.row["finger_force_left_n"] > 1.0 and result.row["finger_force_right_n"] > 1.0
    assert result.scene.model.neq == 1  # only the finger coupling: no weld was added


def test_idle_pop_completes_the_list_when_poses_are_never_reached(cube: Path, cache: dict) -> None:
    """t_eps 0.1 mm / o_eps 1e-4 rad are never met: every pose command pops after more than
    10 idle control steps (reference quirk 9) and the pick still ends with a verdict."""
    task = make_task("fr3", "left", cube, object=CENTRE, pick={"t_eps": 1e-4, "o_eps": 1e-4})
    result = run(task, 0, cache)
    assert result.failure_reason != "timeout"
    trace = result.trace
    rows = {phase: int(np.sum(trace.phase == phase)) for phase in set(trace.phase)}
    chunks_per_step = math.ceil(round(task.control_dt / 0.002) * 0.002 / SERVO_CHUNK_S - 1e-9)
    assert rows["open_gripper:pregrasp"] > IDLE_POP_STEPS * chunks_per_step
    assert result.success, result.row["error_message"]
    # The idle count is the controller's num_last_cmd: reset by a new target, not by a pop.
    # Once past 10 at the grasp, the closing commands (same target) pop one per control step.
    closing = task.pick.gripper_change_steps * chunks_per_step
    assert rows["close_gripper:grasp"] == closing
    assert rows["update_specific:grasp"] == chunks_per_step  # pops at once, idle still > 10
    assert rows["close_gripper:lift"] > IDLE_POP_STEPS * chunks_per_step  # new target: reset


def test_strict_success_measures_the_hold(cube: Path, cache: dict) -> None:
    task = make_task("fr3", "left", cube, object=CENTRE, pick={"semantics": "strict"})
    result = run(task, 0, cache)
    assert result.success, result.row["error_message"]
    row = result.row
    assert 0.0 <= row["slip_m"] < task.pick.max_slip
    events = [text for _, text in result.trace.events]
    assert "validity: hold" in events
    hold_start = next(t for t, text in result.trace.events if text == "validity: hold")
    assert result.trace.time[-1] - hold_start >= task.pick.hold_time - 1e-6


def test_strict_slip_bound_is_dropped(cube: Path, cache: dict) -> None:
    """Strict: slip in the hold (object motion relative to the TCP) above max_slip is dropped,
    though the reference verdict would pass the same episode (test above: success)."""
    pick = {"semantics": "strict", "max_slip": 1e-9}
    result = run(make_task("fr3", "left", cube, object=CENTRE, pick=pick), 0, cache)
    assert result.failure_reason == "dropped"
    assert "slipped" in result.row["error_message"]
    assert result.row["slip_m"] > 1e-9
    reference = run(make_task("fr3", "left", cube, object=CENTRE), 0, cache)
    assert reference.success, reference.row["error_message"]


def test_strict_finger_force_threshold(cube: Path, cache: dict) -> None:
    """Strict: 100 N per finger is more than the gripper squeezes -> no_contact after closing."""
    task = make_task(
        "fr3", "left", cube, object=CENTRE, pick={"semantics": "strict", "min_finger_force": 100.0}
    )
    result = run(task, 0, cache)
    assert result.failure_reason == "no_contact"
    assert "after closing" in result.row["error_message"]


def test_open_final_gripper_state_does_not_lift(cube: Path, cache: dict) -> None:
    """final_gripper_state 1 keeps the gripper open: no contact check, the object stays."""
    task = make_task("fr3", "left", cube, object=CENTRE, pick={"final_gripper_state": 1})
    result = run(task, 0, cache)
    assert result.failure_reason == "lift_below_threshold"
    assert abs(result.row["lift_height_m"]) < 0.005


def test_episode_length_limit_is_a_timeout(cube: Path, cache: dict) -> None:
    task = make_task("fr3", "left", cube, object=CENTRE, max_episode_length=15)
    result = run(task, 0, cache)
    assert result.failure_reason == "timeout"
    assert result.row["sim_steps"] == 15 * round(task.control_dt / 0.002)


def test_return_to_pregrasp_runs_the_retreat(cube: Path, cache: dict) -> None:
    task = make_task("fr3", "left", cube, object=CENTRE, pick={"return_to_pregrasp": True})
    result = run(task, 0, cache)
    assert result.success, result.row["error_message"]
    events = [text for _, text in result.trace.events]
    assert any(text.startswith("segment retreat") for text in events)
    end = result.trace.ee_pose[-1, :3]
    assert np.linalg.norm(end - result.trace.T_world_pregrasp[:3, 3]) < task.pick.t_eps


def test_fixed_orientation_replaces_the_grasp_orientation(cube: Path, cache: dict) -> None:
    """fixed_orientation (wxyz, arm-base frame) overrides the chosen orientation after the
    feasibility test (reference quirk 13): the executed grasp is top-down with the hand's x
    along base x, at the chosen grasp's EE position (so it may or may not hold the cube)."""
    task = make_task(
        "fr3", "left", cube, object=CENTRE, pick={"fixed_orientation": (0.0, 1.0, 0.0, 0.0)}
    )
    result = run(task, 0, cache)
    assert result.failure_reason not in ("error", "plan_failed"), result.row["error_message"]
    scene = result.scene
    T_base_grasp = np.linalg.inv(scene.T_world_base("left")) @ result.trace.T_world_grasp
    assert np.allclose(T_base_grasp[:3, :3], np.diag([1.0, -1.0, -1.0]), atol=1e-9)
    # Only the quaternions are replaced: the pre-grasp stays where the candidate's own approach
    # axis put it, pre_grasp_offset behind its grasp position.
    trace = result.trace
    candidate = trace.candidate_T_world_ee[trace.candidate_status == "chosen"][0]
    assert np.allclose(trace.T_world_grasp[:3, 3], candidate[:3, 3], atol=1e-9)
    expected = candidate[:3, 3] - task.pick.pre_grasp_offset * candidate[:3, 2]
    assert np.allclose(trace.T_world_pregrasp[:3, 3], expected, atol=1e-9)
    assert np.allclose(trace.T_world_pregrasp[:3, :3], trace.T_world_grasp[:3, :3], atol=1e-9)
