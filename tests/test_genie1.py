"""Genie1 and the Franka with a Robotiq 2F-85 as the reference runs them: its shared task files
mapped and run with the example objects, Genie1's single_pick verdict (contact and velocities,
no lift), its batch feasibility and three-axis filters, and the tune grid over them."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from harness.config import AxisFilter
from harness.episode.pipeline import run_episode
from harness.episode.spec import EpisodeSpec
from harness.interndata import InternDataPick, load_interndata_tasks

BOTTLE = "objects/recyclable_garbage/bottle_0/Aligned_obj.usd"
GENIE1 = "tasks/genie1"
ROBOTIQ = "tasks/franka_robotiq85_put_the_trashcan_in_trashcan_part0.yaml"
# Failure stages at which the row names the IK residual (with the joint at its limit), or the
# colliding pair in its message.
REACH_STAGES = ("plan:ik_pregrasp", "plan:ik_grasp", "plan:lift")


def _picks(examples_dir: Path, name: str, objects: tuple[str, ...]) -> list[InternDataPick]:
    bottle = str(examples_dir / BOTTLE)
    return load_interndata_tasks(
        examples_dir / name, None, {obj: bottle for obj in objects}, check_grasps=True
    )


def _rows(pick: InternDataPick, seeds: range) -> list[dict]:
    return [
        run_episode(EpisodeSpec(task=pick.task, seed=seed, episode_index=i)).row
        for i, seed in enumerate(seeds)
    ]


def _assert_located(rows: list[dict]) -> None:
    """No error row; every failure has its stage and message, a plan failure its residual or
    its colliding pair."""
    for row in rows:
        assert row["failure_reason"] != "error", row.get("error_message")
        if row["success"]:
            continue
        assert row["failure_stage"] and row["error_message"], row
        if row["failure_stage"] in REACH_STAGES:
            residual = row["ik_residual_mm"]
            reached = residual is not None and not math.isnan(residual) and residual > 0
            assert reached or "collision" in row["error_message"], row


def test_genie1_files_map_with_the_references_pick_semantics(examples_dir: Path) -> None:
    (left,) = _picks(
        examples_dir, f"{GENIE1}/genie1_left_single_pick_banana.yaml", ("pick_object_left",)
    )
    right_file = f"{GENIE1}/genie1_right_single_pick_banana.yaml"
    (right,) = _picks(examples_dir, right_file, ("pick_object_right",))
    (pnp,) = _picks(
        examples_dir, f"{GENIE1}/genie1_left_single_pnp_banana.yaml", ("pick_object_left",)
    )
    for pick, arm in ((left, "left"), (right, "right"), (pnp, "left")):
        task = pick.task
        assert (task.robot, task.arm) == ("genie1", arm)
        assert task.pick.use_batch is True  # the robot entry's use_batch: True
        assert task.pick.robot_ignore_substring == ["material", "table"]
        assert task.pick.gripper_change_steps == 20
        assert task.pick.lift_th == 0.0
        assert task.home == [-1.069, 0.608, 0.279, -1.278, 0.727, 1.489, -0.186] or arm == "right"
    # Three-axis filters; the right arm's x filter is forward 45; single_pnp's z is a band.
    assert left.task.pick.axis_filters() == {
        "filter_x_dir": AxisFilter(direction="backward", angles=(135.0,)),
        "filter_y_dir": AxisFilter(direction="downward", angles=(120.0,)),
        "filter_z_dir": AxisFilter(direction="forward", angles=(135.0,)),
    }
    assert right.task.pick.filter_x_dir == AxisFilter(direction="forward", angles=(45.0,))
    assert pnp.task.pick.filter_z_dir == AxisFilter(direction="forward", angles=(135.0, 45.0))
    assert any("collision_activation_distance" in note for note in pnp.skipped)
    # The file's regions: the robot 0.80-0.85 m back, 0.73-0.85 m above the floor; per arm.
    assert left.task.robot_placement is not None
    assert left.task.robot_placement.pos_range == ((0.0, -0.85, -0.85), (0.0, -0.80, -0.73))
    assert right.task.target_object.placement is not None
    assert right.task.target_object.placement.pos_range == ((-0.15, -0.16, 0.0), (0.25, 0.0, 0.0))


def test_genie1_single_pick_succeeds_on_contact_and_velocities_alone(examples_dir: Path) -> None:
    """The reference's single_pick (lift_th 0, no post-grasp offset): no lift command, and
    success is a finger on the object with every velocity under 5 (pick.py is_success)."""
    (pick,) = _picks(
        examples_dir, f"{GENIE1}/genie1_left_single_pick_banana.yaml", ("pick_object_left",)
    )
    rows = _rows(pick, range(3300, 3303))
    _assert_located(rows)
    successes = [row for row in rows if row["success"]]
    assert successes, [row["failure_reason"] for row in rows]
    for row in successes:
        assert row["post_grasp_offset"] == 0.0 and row["n_tested"] == 20  # batch: all tested
        assert abs(row["lift_height_m"]) < 0.01  # nothing lifted it
        assert max(row["finger_force_left_n"], row["finger_force_right_n"]) > 0.0
        assert row["max_joint_vel"] < 5.0 and row["max_object_vel"] < 5.0


@pytest.mark.slow
def test_the_shared_genie1_and_robotiq_files_run_with_every_failure_located(
    examples_dir: Path,
) -> None:
    files = {
        f"{GENIE1}/genie1_right_single_pick_banana.yaml": ("pick_object_right",),
        f"{GENIE1}/genie1_left_single_pnp_banana.yaml": ("pick_object_left",),
        f"{GENIE1}/genie1_dual_pnp_lr_peach.yaml": ("pick_object_left", "pick_object_right"),
        ROBOTIQ: ("trash_0",),
    }
    for name, objects in files.items():
        picks = _picks(examples_dir, name, objects)
        assert picks
        for pick in picks:
            rows = _rows(pick, range(3300, 3303))
            assert len(rows) == 3
            _assert_located(rows)
    (robotiq,) = _picks(examples_dir, ROBOTIQ, ("trash_0",))
    assert robotiq.task.robot == "franka_robotiq85"
    # The file's trashcan (an ArticulatedObject without a path) is left out with a note.
    assert [obj.name for obj in robotiq.task.objects] == ["trash_0"]
    assert any("skipped object 'trashcan'" in note for note in robotiq.skipped)


def test_the_tune_grid_holds_a_three_axis_tasks_third_filter() -> None:
    """The tune grid varies the approach (EE z) and facing (EE y) filters of a Genie1 task and
    keeps its closing-axis filter (filter_x_dir) in every point."""
    from harness.runs.expansion import expand
    from harness.tuning.grid import current_setting, load_inputs, tune_sweep

    tasks, axes, _ = load_inputs([Path("tasks/pick/genie1_left.yaml")])
    assert current_setting(tasks[0]) == {
        "pick.approach_filter": ["forward", 135.0],
        "pick.facing_filter": ["downward", 120.0],
    }
    sweep = tune_sweep(tasks, axes, step=30, bands=0, episodes=1, seed=0)
    episodes = expand(sweep, None)
    assert len(episodes) > 4
    held = AxisFilter(direction="backward", angles=(135.0,))
    settings = set()
    for episode in episodes:
        pick = episode.task.pick
        assert pick.filter_x_dir == held
        assert pick.filter_y_dir is None and pick.filter_z_dir is None  # replaced by the point
        settings.add((str(pick.approach_filter), str(pick.facing_filter)))
    assert len(settings) == len(episodes)
