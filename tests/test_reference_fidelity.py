"""Reference fidelity, part 2 (issue 22): the reference's pace, the force-controlled grasp and
the validity verdict's fixes, each on real episodes (or the real scene's geometry).

The planning-world rules (target out for the grasp, attached for the lift, the robot's ignore
list replacing the default) are tested on the collision checker in ``test_planning_world.py``
and the feasibility rule (no lift in the reference's forward test) in
``test_episode.py::test_forward_test_and_the_lift``.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from helpers import TASKS_DIR, episode

from harness.config import apply_overrides, load_task
from harness.config.pick import REFERENCE_SPEED_SCALE
from harness.episode.scene_cache import get_scene
from harness.pick.penetration import TablePenetration
from harness.sim import TABLE_NAME


@pytest.fixture(scope="module")
def cache() -> dict:
    return {}


def test_reference_pace_is_the_default_and_keeps_joint_speeds_sane(cache: dict) -> None:
    """Default speed_scale is the reference's pace, 0.01 s waypoints at 1/30 s steps = 0.3
    (template_controller.py): the row says so, the plan plays more than twice as long as at
    full speed on the same seed, and no joint comes near its velocity limit."""
    assert pytest.approx(0.01 * 30) == REFERENCE_SPEED_SCALE
    task = load_task(TASKS_DIR / "lift2_left.yaml")  # seed 3: within reach in the reference region
    paced = episode(task, 3, cache).row
    fast = episode(apply_overrides(task, {"pick.speed_scale": 1.0}), 3, cache).row
    assert not paced["failure_reason"] and not fast["failure_reason"]
    assert paced["speed_scale"] == pytest.approx(0.3) and fast["speed_scale"] == 1.0
    assert paced["chosen_index"] == fast["chosen_index"]
    assert paced["traj_duration_s"] > 2.0 * fast["traj_duration_s"]
    robot = get_scene(task, cache).scene.robot
    slowest_limit = float(np.min(robot.velocity_limits(robot.arms["left"].joints)))
    assert paced["max_joint_vel"] < 0.5 * slowest_limit, paced["max_joint_vel"]
    assert fast["max_joint_vel"] > 0.9 * slowest_limit  # at full speed: at the limit


@pytest.mark.parametrize(
    ("task_file", "force", "seed"), [("fr3", 70.0, 2), ("lift2_left", 85.7, 3)]
)
def test_force_controlled_grasp_reaches_its_force_limit_on_a_cube(
    cache: dict, task_file: str, force: float, seed: int
) -> None:
    """A real parallel gripper closes until its force limit (Franka Hand 70 N continuous,
    R5a 85.7 N: arx5-sdk 1.5 N m over 0.0175 m of opening per motor rad): both pads press the
    4 cm cube with it when the closing ends and after the hold. The position grasp presses
    kp * w / 4 (5 N at kp 500). Lift-2 seed 3: in the reference's region (issue 33) seeds 0-2
    are beyond the arm's reach."""
    task = load_task(TASKS_DIR / f"{task_file}.yaml")
    row = episode(task, seed, cache).row
    assert row["grip_force_limit_n"] == force
    assert row["finger_force_left_n"] == pytest.approx(force, rel=0.05)
    assert row["finger_force_right_n"] == pytest.approx(force, rel=0.05)
    assert row["min_finger_force_n"] == pytest.approx(force, rel=0.05)
    if task_file == "fr3":
        position = apply_overrides(task, {"robot.gripper.grasp": "position"})
        weak = episode(position, seed, cache).row
        assert max(weak["finger_force_left_n"], weak["finger_force_right_n"]) < 6.0


def test_a_late_two_finger_close_is_valid(cache: dict) -> None:
    """A slow gripper (FR3 finger damping kv 17000: the 140 N servo closes at ~8 mm/s) has one
    finger on the cube when the closing window ends (the other at 0 N), closes during the lift
    and holds with both fingers at 70 N through the hold and the tug: valid, since the
    two-finger check is after the hold (it was ``one_finger`` when judged at the closing)."""
    # The 0.1 kg cube this was measured on: since the cube runs at its object.yaml 0.05 kg
    # (issue 22), these slowed fingers end the closing window with no contact on seeds 2-3
    # (no_contact; measured, cause not yet analysed), which is not the case this test is about.
    slow = {"robot.gripper.kv": 17000.0, "object.mass": 0.1}
    task = apply_overrides(load_task(TASKS_DIR / "fr3.yaml"), slow)
    row = episode(task, 2, cache).row
    assert min(row["finger_force_left_n"], row["finger_force_right_n"]) < 0.5
    assert row["success"] and row["min_finger_force_n"] > 65.0
    assert row["valid"], (row["invalid_reason"], row["error_message"])


def test_penetration_counts_a_geom_whose_centre_is_off_the_table(cache: dict) -> None:
    """A finger pad centred 3 mm past the table's edge, 1 cm below the top, has its inner part
    in the slab: counted (the old centre test said 0). The same pad 1 cm clear of the edge,
    as a carriage standing beside the slab, is not in it."""
    task = load_task(TASKS_DIR / "fr3.yaml")
    scene = get_scene(task, cache).scene
    model, data = scene.model, scene.data
    mujoco.mj_forward(model, data)
    meter = TablePenetration(scene)
    assert meter.depth(data) == 0.0  # the baseline: nothing in the slab at home
    pad = model.geom("left_rightfinger_pad").id
    table = model.geom(TABLE_NAME).id
    edge_x = float(model.geom_pos[table][0] + model.geom_size[table][0])
    half_x = float(model.geom_size[pad][0])
    data.geom_xmat[pad] = np.eye(3).reshape(-1)
    data.geom_xpos[pad] = [edge_x + 0.003, 0.0, -0.01]
    assert meter.depth(data) == pytest.approx(half_x - 0.003, abs=2e-4)
    data.geom_xpos[pad] = [edge_x + half_x + 0.01, 0.0, -0.01]
    assert meter.depth(data) == 0.0
    mujoco.mj_forward(model, data)  # the scene's own poses again
