"""A handover's second pick runs from the state the reference gives it (issue 33 point 8): the
first arm's pick and goto__pose first, then the second arm's pick of the object in mid-air,
judged by its own reference rule; valid after the first gripper opened."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from helpers import HANDOVER_GOTO, write_handover_file

from harness.config import PickConfig
from harness.config.errors import ConfigError
from harness.config.handover import GotoPoseConfig
from harness.episode.handover import first_pick_task
from harness.episode.pipeline import run_episode
from harness.episode.spec import EpisodeSpec
from harness.interndata import load_interndata_tasks
from harness.interndata.dependencies import Prelude, SkillRef, handover_prelude
from harness.pick.executor_validity import judged_validity
from harness.pick.goto_pose import CUROBO_BATCH_SIZE, goto_reached, goto_targets
from harness.pick.outcome import ValidityMeasure
from harness.transforms import invert_T

BOTTLE = "objects/recyclable_garbage/bottle_0/Aligned_obj.usd"


def _ref(phase: int, arm: str, index: int, name: str, target: str | None = "obj") -> SkillRef:
    key = f"tasks[0].skills[0].split_aloha[{phase}].{arm}[{index}]"
    return SkillRef(0, "split_aloha", phase, arm, index, key, name, target)


# --------------------------------------------------------------------------------------------
# The phase logic, without a simulator


def test_the_prelude_is_the_other_arms_pick_then_its_goto() -> None:
    first, goto = _ref(0, "left", 0, "pick"), _ref(0, "left", 1, "goto__pose")
    second = _ref(1, "right", 0, "pick")
    release = _ref(2, "left", 0, "gripper__action", None)
    assert handover_prelude(second, [first, goto, second, release]) == Prelude(first, goto)
    assert handover_prelude(second, [first, second]) == Prelude(first, None)
    assert handover_prelude(first, [first, goto, second]) is None  # nothing before it
    # Not a handover: the same arm picks again, or a place comes between.
    again = _ref(1, "left", 0, "pick")
    assert handover_prelude(again, [first, goto, again]) is None
    place = _ref(0, "left", 1, "place")
    assert handover_prelude(second, [first, place, second]) is None
    # Skills side by side in one phase do not run before each other.
    beside = _ref(0, "right", 0, "pick")
    assert handover_prelude(beside, [first, beside]) is None


def test_goto_targets_follow_the_reference_rules() -> None:
    """bowl.yaml's goto: the object at [0.3, -0.25, 0.1] +- 5 cm, its y axis within 30 deg of
    the base z, the end effector's x within 70 deg of forward, held as it is now."""
    config = GotoPoseConfig.model_validate(HANDOVER_GOTO | {"objects": ["obj"]})
    rng = np.random.default_rng(4)
    T_obj_ee = np.eye(4)
    T_obj_ee[:3, :3] = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    T_obj_ee[:3, 3] = [0.02, -0.01, 0.13]
    targets, passed = goto_targets(config, T_obj_ee, rng)
    assert targets.shape == (CUROBO_BATCH_SIZE, 4, 4)
    assert 0 < passed < 3000
    T_base_obj = targets @ invert_T(T_obj_ee)
    offsets = T_base_obj[:, :3, 3] - np.array([0.3, -0.25, 0.1])
    assert np.all(np.abs(offsets) <= 0.05 + 1e-12)
    assert np.all(T_base_obj[:, 2, 1] > math.cos(math.radians(30)))  # object y near base z
    assert np.all(targets[:, 0, 0] >= math.cos(math.radians(70)))  # EE x forward
    # The gripper constraint puts the end effector itself at the position.
    gripper = config.model_copy(update={"position_constraint": "gripper", "max_noise_m": 0.0})
    targets, _ = goto_targets(gripper, T_obj_ee, rng)
    assert np.allclose(targets[:, :3, 3], [0.3, -0.25, 0.1])


def test_goto_success_is_position_or_orientation() -> None:
    """goto_pose.py is_success: 5 mm **or** 0.087 rad."""
    goal = np.eye(4)
    far_but_aligned = np.eye(4)
    far_but_aligned[:3, 3] = [0.02, 0.0, 0.0]
    assert goto_reached(far_but_aligned, goal)[0]
    turned = np.eye(4)
    turned[:3, :3] = [
        [1, 0, 0],
        [0, math.cos(0.1), -math.sin(0.1)],
        [0, math.sin(0.1), math.cos(0.1)],
    ]
    assert goto_reached(turned, goal)[0]  # 0 mm away
    turned[:3, 3] = [0.0, 0.006, 0.0]
    passed, millimetres, radians = goto_reached(turned, goal)
    assert not passed and math.isclose(millimetres, 0.006) and math.isclose(radians, 0.1)


def test_a_valid_grasp_the_open_first_gripper_still_touches_is_no_handover() -> None:
    """The validity term ``first_gripper_contact``: after the release the opened first
    gripper carries no force on the object; NaN (no handover) passes."""
    pick = PickConfig(lift_th=0.02)
    held = ValidityMeasure(
        ran=True, table_penetration_m=0.0, lift_height_m=0.1, closing_forces=(30.0, 30.0),
        finger_forces=(30.0, 30.0), hold_slip_m=0.001, hold_rotation_rad=0.01, robustness_g=4.0,
    )  # fmt: skip
    assert judged_validity(pick, held).valid  # any other pick: NaN
    held.first_gripper_force_n = 0.0
    assert judged_validity(pick, held).valid
    held.first_gripper_force_n = 1.5
    touched = judged_validity(pick, held)
    assert not touched.valid and touched.invalid_reason == "first_gripper_contact"
    assert "1.50 N" in touched.message
    # The rule's bound is the sweepable pick.max_first_gripper_force (chosen, 0 N).
    assert judged_validity(PickConfig(lift_th=0.02, max_first_gripper_force=2.0), held).valid
    held.hold_slip_m = 0.05  # an earlier cause wins
    assert judged_validity(pick, held).invalid_reason == "slipped_in_hold"


def test_goto_keys_are_checked() -> None:
    with pytest.raises(ValueError, match="align_ref_axis is required"):
        GotoPoseConfig.model_validate({"position": [0.3, 0.0, 0.1], "align_obj_axis": [0, 1, 0]})
    with pytest.raises(ValueError, match="interp_nums >= 2"):
        GotoPoseConfig.model_validate(
            {"position": [0.3, 0.0, 0.1], "euler": [0, 0, 0]} | {"interp_nums": 3}
        )


# --------------------------------------------------------------------------------------------
# The handover file


def _handover_picks(examples_dir: Path, tmp_path: Path):
    subs = {"pick_object_left": str(examples_dir / BOTTLE)}
    path = write_handover_file(examples_dir, tmp_path)
    return load_interndata_tasks(path, asset_root=None, objects=subs)


def test_the_handover_file_maps_to_a_runnable_second_pick(
    examples_dir: Path, tmp_path: Path
) -> None:
    first, second = _handover_picks(examples_dir, tmp_path)
    assert first.task.handover is None and first.task.not_runnable is None
    task = second.task
    assert task.not_runnable is None and task.arm == "right"
    prelude = task.handover
    assert prelude is not None and prelude.arm == "left"
    assert prelude.first_key == "tasks[0].skills[0].split_aloha[0].left[0]"
    assert prelude.goto_key == "tasks[0].skills[0].split_aloha[0].left[1]"
    assert prelude.pick == first.task.pick  # the first pick's own block
    assert prelude.home == first.task.home and prelude.home_noise_std == first.task.home_noise_std
    assert prelude.goto_pose is not None and prelude.goto_pose.position == (0.3, -0.25, 0.1)
    # The second pick's own rule: no lift, no lift_th (success = contact and velocities).
    assert task.pick.lift_th == 0.0 and task.pick.post_grasp_offset_max == 0.0
    assert any("takes the object from the left gripper" in note for note in second.skipped)
    # Its first phase is the first pick as a task of the same scene, without a validity phase.
    phase1 = first_pick_task(task)
    assert phase1.arm == "left" and phase1.pick == prelude.pick.model_copy(
        update={"validity": False}
    )
    assert phase1.objects == task.objects and phase1.physics == task.physics
    assert phase1.robot_placement == task.robot_placement


def test_a_bad_goto_key_is_located_in_the_file(examples_dir: Path, tmp_path: Path) -> None:
    path = write_handover_file(examples_dir, tmp_path)
    text = path.read_text(encoding="utf-8").replace("align_obj_tol: 30", "align_obj_tol: -30")
    path.write_text(text, encoding="utf-8")
    subs = {"pick_object_left": str(examples_dir / BOTTLE)}
    with pytest.raises(ConfigError) as raised:
        load_interndata_tasks(path, asset_root=None, objects=subs)
    message = str(raised.value)
    assert "tasks[0].skills[0].split_aloha[0].left[1].align_obj_tol" in message
    assert message.startswith(str(path))


# --------------------------------------------------------------------------------------------
# End to end: the second pick runs


# Seeds of write_handover_file's handover (the bottle for the object), from running seeds 0-69
# under the default physics (the noslip pass, issue 33): 33 runs through all three phases to a
# reference success with both right fingers on the bottle (34 / 41 N) that is valid; 4 reaches the
# second pick, whose own pre-grasp is out of reach; 1 and 10 stop in the first pick and in the
# goto. The reference rule accepts one finger (pick.py is_success: the force between the object
# and at least one finger link > 0): 5 more successes (3, 17, 26, 32, 69) had one right finger at
# 0 N at the verdict and 80-82 N on the other (the two pads' 2 x 40 N; our reading: the fingers
# are coupled, so while the still-closed left gripper holds the bottle off-centre the first finger
# to touch stops both and takes the whole squeeze), and 59 had both. The both-fingers claim below
# holds for this seed, not for every success. Before the noslip pass seed 17 had both fingers on
# (40 / 38 N) and seed 3 stopped in the goto: without the creep the bottle sits otherwise in the
# left hand, so the goto and the second pick start elsewhere (seed 17's bottle 5.1 cm above the
# right arm base, not 6.5 cm); seed 17 with `physics.noslip_iterations` 0 and pad_torsion 0.01
# gives its old row back (and seed 3 its goto stop), while 33 and 10 behave as pinned here.
SECOND_PICK_SUCCESS = 33
SECOND_PICK_PLAN_FAILED = 4
STOPPED_EARLY = {1: "first_pick:plan:ik_pregrasp", 10: "goto_pose:plan:targets"}


@pytest.mark.slow
def test_the_second_pick_runs_from_mid_air_and_is_judged_by_its_rule(
    examples_dir: Path, tmp_path: Path
) -> None:
    """Seed 33 through all three phases: a valid reference success of the right arm from the
    bottle in mid-air, both right fingers on it at the verdict (the reference rule needs one;
    see the seeds above), then seeds that stop at the second pick's, the first pick's and the
    goto's plan."""
    first, second = _handover_picks(examples_dir, tmp_path)
    cache: dict = {}

    def row_of(task, seed: int) -> dict:
        return run_episode(EpisodeSpec(task=task, seed=seed, episode_index=seed), cache).row

    seed = SECOND_PICK_SUCCESS
    row = row_of(second.task, seed)
    first_row = row_of(first.task, seed)
    assert first_row["success"]  # the first phase is this pick, run alone from the same reset
    assert row["failure_reason"] == "" and row["failure_stage"] == "" and row["success"]
    assert row["arm"] == "right" and row["post_grasp_offset"] == 0.0  # no lift
    # Candidates drawn where the object is held: in mid-air beside the right arm base (its
    # frame: z up, y left; an object on the table lies about 4 cm below the base).
    assert row["object_z_m"] > 0.03 and row["object_y_m"] > 0.2
    assert row["lift_height_m"] > 0.05  # still above where it stood at the reset
    # The reference rule (pick.py is_success, lift_th 0) needs one finger; on this seed both touch.
    assert min(row["finger_force_left_n"], row["finger_force_right_n"]) > 0.0
    # Valid: after the left gripper opened, the right one alone holds it through hold and tug.
    assert row["valid"] and row["first_gripper_force_n"] == 0.0 and row["robustness_g"] > 0.0
    # The goto ran: its end effector's distance from the goal is measured (not judged).
    assert np.isfinite(row["goto_error_mm"]) and np.isfinite(row["goto_error_rad"])

    row = row_of(second.task, SECOND_PICK_PLAN_FAILED)
    assert row["failure_reason"] == "plan_failed" and row["failure_stage"] == "plan:ik_pregrasp"
    assert np.isfinite(row["goto_error_mm"]) and row["object_z_m"] > 0.03

    for seed, stage in STOPPED_EARLY.items():
        row = row_of(second.task, seed)
        assert row["failure_reason"] == "plan_failed" and row["failure_stage"] == stage
        assert row["error_message"].startswith(stage.split(":")[0] + ": ")
