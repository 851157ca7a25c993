"""Issue 25: rows locate failures and recordings, videos and headlines show the cause.

Real episodes (MuJoCo, placo): the placement columns against the scene's own poses, a plan
failure's stage and failing configuration posed in its recording and its video, the recording
policy per outcome class, and headlines that never call an invalid grasp just "SUCCESS"."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from helpers import FAR, body_entities, flatten, make_task, read_back, write_box

from harness.episode import EpisodeSpec, run_episode
from harness.episode.spec import EpisodeSpec as Spec
from harness.runs.worker import _wants_recording
from harness.transforms import invert_T
from harness.viz.headline import headline, outcome_class
from harness.viz.recording import record_episode


@pytest.fixture(scope="module")
def cube(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_box(tmp_path_factory.mktemp("cause_cube"), (0.04, 0.04, 0.04), "cube")


@pytest.fixture(scope="module")
def far_result(cube: Path):
    """FR3 with the cube 1.07 m away: the reference goes on with the last tested candidate and
    its plan fails (out of reach)."""
    task = make_task("fr3", "left", cube, object=FAR)
    return task, run_episode(EpisodeSpec(task=task, seed=0), {})


def test_placement_columns_are_the_object_pose_in_the_arm_base_frame(far_result) -> None:
    _, result = far_result
    row, scene = result.row, result.scene
    T_base_object = invert_T(scene.T_world_base("left")) @ scene.T_world_object("target")
    # The scene now holds the reset state the episode planned from (nothing was executed).
    assert row["object_x_m"] == pytest.approx(T_base_object[0, 3], abs=1e-9)
    assert row["object_y_m"] == pytest.approx(T_base_object[1, 3], abs=1e-9)
    assert row["object_z_m"] == pytest.approx(T_base_object[2, 3], abs=1e-9)
    distance = math.hypot(row["object_x_m"], row["object_y_m"])
    assert row["object_distance_m"] == pytest.approx(distance)
    assert 1.0 < row["object_distance_m"] < 1.15  # placed 1.07 m from the FR3's base
    yaw = math.degrees(math.atan2(T_base_object[1, 0], T_base_object[0, 0]))
    assert row["object_yaw_deg"] == pytest.approx(yaw, abs=1e-6)


def test_a_plan_failure_is_located_and_its_configuration_kept(far_result) -> None:
    _, result = far_result
    row, trace = result.row, result.trace
    assert row["failure_reason"] == "plan_failed"
    stage = row["error_message"].split(":", 1)[0]
    assert row["failure_stage"] == f"plan:{stage}"
    assert trace is not None and trace.failure_qpos is not None
    active = result.scene.arms["left"].active_qpos
    moved = np.abs(trace.failure_qpos[active] - trace.qpos_start[active])
    assert moved.max() > 0.05  # the best IK attempt, not the home pose
    others = np.setdiff1d(np.arange(len(trace.qpos_start)), active)
    assert np.array_equal(trace.failure_qpos[others], trace.qpos_start[others])
    if "collision" in row["error_message"]:
        assert row["collision_a"] and row["collision_b"]
    else:
        assert row["collision_a"] == row["collision_b"] == ""


def test_plan_failure_recording_poses_the_failing_configuration(far_result, tmp_path) -> None:
    task, result = far_result
    path = record_episode(result, tmp_path / "plan_failed.rrd", task)
    rows, values = read_back(path)
    for body in body_entities(rows):  # reset pose, then the configuration that failed
        assert rows[body]["Transform3D:translation"] == 2, body
    cause = flatten(values["/world/cause#Points3D:labels"])
    assert len(cause) == 1 and "out of reach" in cause[0]
    document = "".join(flatten(values["/verdict#TextDocument:text"]))
    assert f"FAILURE: plan_failed at {result.row['failure_stage']}" in document
    assert cause[0] in document


def test_plan_failure_video_holds_on_the_failing_configuration(far_result, tmp_path) -> None:
    imageio = pytest.importorskip("imageio.v3")
    from harness.viz.video import HOLD_S, START_S, write_episode_video

    _, result = far_result
    video = tmp_path / "plan_failed.mp4"
    frames = write_episode_video(result, video, fps=10, width=320, height=240)
    assert frames == round(START_S * 10) + round(HOLD_S * 10)
    movie = imageio.imread(video)
    poster = imageio.imread(video.with_suffix(".png"))
    assert poster.shape == (240, 320, 3)
    # The first frame (reset pose) and the last (failing configuration) differ in the scene
    # below the caption band.
    body = slice(40, 200)
    assert np.abs(movie[0, body].astype(int) - movie[-1, body].astype(int)).mean() > 1.0
    # The caption band is drawn: its red headline pixels (failed) are present.
    band = poster[:40].reshape(-1, 3).astype(int)
    assert np.any((band[:, 0] > 180) & (band[:, 1] < 80) & (band[:, 2] < 80))


ROWS = {
    "success_valid": {"success": True, "valid": True, "invalid_reason": ""},
    "success_invalid:table_penetration": {
        "success": True,
        "valid": False,
        "invalid_reason": "table_penetration",
        "table_penetration_m": 0.0123,
    },
    "failure:plan_failed": {
        "success": False,
        "valid": False,
        "invalid_reason": "not_run",
        "failure_reason": "plan_failed",
        "failure_stage": "plan:approach",
        "collision_a": "link6",
        "collision_b": "table",
    },
}


def test_outcome_classes_and_headlines_carry_both_verdicts() -> None:
    for name, row in ROWS.items():
        assert outcome_class(row) == name
    assert headline(ROWS["success_valid"]) == "SUCCESS · VALID"
    invalid = headline(ROWS["success_invalid:table_penetration"])
    assert invalid.startswith("REFERENCE SUCCESS · INVALID: table_penetration")
    assert "12.3 mm" in invalid
    assert headline(ROWS["failure:plan_failed"]) == (
        "FAILURE: plan_failed at plan:approach (link6 hits table)"
    )


@pytest.mark.parametrize(
    "policy, recorded",
    [
        ("failures", {"success_invalid:table_penetration", "failure:plan_failed"}),
        ("invalid", {"success_invalid:table_penetration"}),
        ("none", set()),
    ],
)
def test_record_policy_per_outcome_class(cube: Path, policy: str, recorded: set[str]) -> None:
    spec = Spec(task=make_task("fr3", "left", cube), seed=0)
    chosen = {name for name, row in ROWS.items() if _wants_recording(spec, row, policy)}
    assert chosen == recorded
