"""Episodes end to end: the canonical tasks on every robot and arm, the failure taxonomy, both
test modes and both timings, determinism, the row schema and the trace."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from helpers import PICK_TASKS, TASKS_DIR, episode, make_task, write_box
from reference_robots import REFERENCE_PLANNER_FILES

from harness.config import PickConfig, apply_overrides, load_task
from harness.episode import (
    INIT_RECORD_TIME_S,
    SETTLE_TIME_S,
    WARMUP_TIME_S,
)
from harness.episode.ids import episode_seed
from harness.episode.scene_cache import get_scene, grasp_file_for
from harness.episode.streams import EpisodeStreams
from harness.failures import FAILURE_REASONS
from harness.grasps import select_candidates
from harness.pick.executor import SERVO_CHUNK_S
from harness.pick.semantics import Semantics
from harness.pick.targets import command_targets
from harness.robots import RobotModel
from harness.runs.store import SCHEMA
from harness.transforms import invert_T

TASK_FILES = PICK_TASKS
ADDED_BY_EXECUTORS = {"worker_peak_rss_mb", "recording", "recording_error", "config_sha256"}


@pytest.fixture(scope="module")
def cube(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_box(tmp_path_factory.mktemp("episode_cube"), (0.04, 0.04, 0.04), "cube")


@pytest.fixture(scope="module")
def cache() -> dict:
    return {}


# --------------------------------------------------------------------------------------------
# The canonical tasks (tasks/pick/*.yaml, default cube)


# Where the table is physical for the arm (Split ALOHA and Lift-2 right-arm files), a tilted
# grasp planned through it (the reference's planning world ignores the table) stops where the
# fingertips meet the table top: measured on split_aloha_right seeds 1, 8 and 9 (approach 24-25
# degrees from vertical), the TCP stops 16-17 mm short with the fingers 1.0-1.4 mm into the
# table, and the grasp still holds (valid). Such a stop is allowed up to this distance.
TABLE_STOP_M = 0.025
TABLE_TOUCH_M = 0.0008  # fingers pressed on the table top (the contact depth MuJoCo allows)


def check_pick(result) -> None:
    """Success, with the object really lifted and the TCP at grasp within 1 cm of the plan --
    or, on a physical table that the fingertips pressed on, within ``TABLE_STOP_M``."""
    row, trace = result.row, result.trace
    assert result.success, f"{row['failure_reason']}: {row['error_message']}"
    # At the verdict: the last row before the validity phase (which tugs the object after it).
    last = int(np.flatnonzero(~np.char.startswith(trace.phase.astype(str), "validity"))[-1])
    z_before, z_after = trace.object_pose[0, 2], trace.object_pose[last, 2]
    assert z_after - z_before > 0.02, (z_before, z_after)
    assert row["lift_height_m"] > 0.02
    table_stop = (
        result.spec.task.physics.table_contact and row["table_penetration_m"] > TABLE_TOUCH_M
    )
    assert row["tcp_grasp_error_m"] < (TABLE_STOP_M if table_stop else 0.01), (
        row["tcp_grasp_error_m"], row["table_penetration_m"]
    )  # fmt: skip


def test_one_fr3_episode_from_the_task_file(cache: dict) -> None:
    task = load_task(TASKS_DIR / "fr3.yaml")
    result = episode(task, 1, cache)
    check_pick(result)
    assert result.row["test_mode"] == "ik" and result.row["timing"] == "toppra"


@pytest.mark.slow
@pytest.mark.parametrize("name", TASK_FILES)
def test_every_robot_and_arm_picks_the_cube(name: str) -> None:
    """Canonical parameters, 10 seeds: every seed is a real pick, or fails where the reference
    fails by its own rule: the arm's reach. Its feasibility test leaves the lift out (pick.py),
    so a chosen candidate whose lift pose lies beyond the arm's reach is ``plan_failed`` at the
    lift (issue 22), and with no feasible candidate it proceeds with the last one tested, which
    fails at the pre-grasp IK; since issue 33 the objects lie in the reference's regions, which
    reach 0.7 m from the arm base, and such a row names its residual past the 5 mm tolerance
    (``ik_residual_mm``). At most 2 seeds fail for any other cause (the bound this test had
    before issue 22 switched the feasibility rule to the reference's)."""
    task = load_task(TASKS_DIR / f"{name}.yaml")
    cache: dict = {}
    failures = []
    lift_out_of_reach = 0
    for seed in range(10):
        result = episode(task, seed, cache)
        row = result.row
        reach = row["failure_stage"] in ("plan:lift", "plan:ik_pregrasp")
        if row["failure_reason"] == "plan_failed" and reach:
            lift_out_of_reach += 1
            assert row["ik_residual_mm"] > 5.0, row["error_message"]  # beyond the tolerance
            continue
        try:
            check_pick(result)
        except AssertionError as exc:
            failures.append(f"seed {seed}: {exc}")
    assert len(failures) <= 2, "\n".join(failures)
    # Real picks on every arm: with the reference's arm placement and rules (issue 22), Split
    # ALOHA left picks 3 of these 10 seeds (7 lifts out of reach), the other arms 5-9.
    assert 10 - lift_out_of_reach - len(failures) >= 3


# The Lift-2 region these seeds were measured in (0.33-0.43 m in front of the arm), before the
# canonical task took the reference's wider region (issue 33).
LIFT2_NEAR = {"pos_range": [[-0.35, -0.30, 0.0], [0.0, -0.20, 0.0]], "yaw_range": [-180, 180]}


@pytest.mark.slow
def test_reference_plans_through_a_physical_table_strict_does_not() -> None:
    """Issue 16 item 1: the reference planner never sees the table, even where robot-table
    contact is physical (the right-arm reference files omit ``neglect_collision_names``).
    Measured on 20 seeds (``harness run tasks/pick/lift2_left.yaml --episodes 20 --set
    physics.table_contact=true``): 20/20 with the reference planning world, 0/20 when the
    planner avoided the table. Here three of those seeds."""
    task = apply_overrides(
        load_task(TASKS_DIR / "lift2_left.yaml"),
        {"physics.table_contact": True, "objects.0.placement": LIFT2_NEAR},
    )
    cache: dict = {}
    for index in range(3):
        # Success and a real lift; the TCP may stop short of the plan (a finger planned into the
        # physical table is stopped by it), so check_pick's 1 cm TCP criterion does not apply.
        result = episode(task, episode_seed(0, index), cache)
        assert result.success, result.row["error_message"]
        assert result.row["lift_height_m"] > 0.02
    strict = apply_overrides(task, {"pick.semantics": "strict"})
    world = Semantics.from_pick(strict.pick).planning_world("cube")
    assert world.check_table and world.table_clearance > 0


@pytest.mark.slow
def test_object_friction_decides_a_heavy_pick() -> None:
    """Issue 16 item 4: ``object.friction`` used to be a no-op (MuJoCo keeps the larger of two
    coefficients, and the pads' always won). With the reference engine's average, a 0.8 kg cube
    squeezed with 5 N per pad slips at friction 0.1 (0.55 at the pads) and holds at 1.5
    (1.25), on the same seeds. Re-pinned (issue 22) from the FR3, whose force-controlled grasp
    now presses 70 N and holds it at either friction, to the Lift-2 at 5 N per pad (Menagerie's
    cap; issue 33 set the R5a to its arx5-sdk 85.7 N), the object in the region it was
    measured in: episodes 1-3 of seed 0 measured 0/3 vs 3/3."""
    base = apply_overrides(
        load_task(TASKS_DIR / "lift2_left.yaml"),
        {"objects.0.placement": LIFT2_NEAR, "robot.gripper.force_limit": 5.0},
    )
    cache: dict = {}
    outcomes = {}
    for friction in (0.1, 1.5):
        task = apply_overrides(base, {"object.mass": 0.8, "object.friction": friction})
        outcomes[friction] = [episode(task, episode_seed(0, index), cache) for index in (1, 2)]
    for low, high in zip(outcomes[0.1], outcomes[1.5], strict=True):
        assert (low.row["object_friction"], high.row["object_friction"]) == (0.1, 1.5)
        assert low.row["failure_reason"] == "dropped" and low.row["lift_height_m"] < 0.01
        assert high.success and high.row["lift_height_m"] > 0.02


# --------------------------------------------------------------------------------------------
# Both test modes, both timings


@pytest.mark.parametrize("test_mode", ["ik", "forward"])
@pytest.mark.parametrize("timing", ["toppra", "ruckig"])
def test_test_modes_and_timings_run_end_to_end(
    cube: Path, cache: dict, test_mode: str, timing: str
) -> None:
    task = make_task("fr3", "left", cube, pick={"test_mode": test_mode, "timing": timing})
    result = episode(task, 2, cache)
    check_pick(result)
    assert result.row["test_mode"] == test_mode and result.row["timing"] == timing
    transport = [t for t in result.trace.events if t[1].startswith("segment transport")]
    assert transport


# --------------------------------------------------------------------------------------------
# Failure taxonomy


def test_upward_only_filter_strict_is_filter_empty(cube: Path, cache: dict) -> None:
    """An approach filter that admits only upward approaches: nothing passes."""
    task = make_task(
        "fr3", "left", cube, pick={"semantics": "strict", "filter_z_dir": ["upward", 30]}
    )
    result = episode(task, 0, cache)
    assert result.failure_reason == "filter_empty"
    assert result.row["n_passed_filter"] == 0 and result.row["filter_outcome"] == "filter_empty"


def test_upward_only_filter_reference_falls_back(cube: Path, cache: dict) -> None:
    """Reference semantics: rows 0..19 of the unfiltered poses are the candidates, and the
    episode goes on with them (reference section 4.4)."""
    task = make_task("fr3", "left", cube, pick={"filter_z_dir": ["upward", 30]})
    result = episode(task, 0, cache)
    row = result.row
    assert row["filter_outcome"] == "fallback" and row["n_passed_filter"] == 0
    assert 0 <= row["chosen_index"] < 20
    assert row["n_tested"] >= 1
    assert row["failure_reason"] != "filter_empty"


def test_object_out_of_reach_strict_is_no_feasible_candidate(cube: Path, cache: dict) -> None:
    far = {"placement": {"pos_range": [[0.75, 0.3, 0.0], [0.75, 0.3, 0.0]]}}  # 1.07 m away
    task = make_task("fr3", "left", cube, object=far, pick={"semantics": "strict"})
    result = episode(task, 0, cache)
    assert result.failure_reason == "no_feasible_candidate"
    assert result.row["n_tested"] >= 1 and result.row["n_feasible"] == 0


def test_object_out_of_reach_reference_proceeds_with_the_last(cube: Path, cache: dict) -> None:
    """Reference: no feasible candidate -> the last one tested is executed, and fails later."""
    far = {"placement": {"pos_range": [[0.75, 0.3, 0.0], [0.75, 0.3, 0.0]]}}
    task = make_task("fr3", "left", cube, object=far)
    result = episode(task, 0, cache)
    assert result.row["n_tested"] == 20
    assert result.failure_reason == "plan_failed"


def test_object_wider_than_the_gripper_is_not_held(tmp_path: Path) -> None:
    """A 12 x 12 x 4 cm box against the FR3's 8 cm opening: the fingers land on its top, close
    on nothing, and lift nothing (dropped: they touched it, then not; or no_contact; strict,
    whose verdict is the validity verdict: not_lifted, i.e. lift_below_threshold)."""
    box = write_box(tmp_path, (0.12, 0.12, 0.04), "wide_box")
    centre = {"placement": {"pos_range": [[0.05, 0.0, 0.0], [0.05, 0.0, 0.0]]}}
    reasons = set()
    for semantics in ("reference", "strict"):
        for seed in (0, 1):
            task = make_task("fr3", "left", box, object=centre, pick={"semantics": semantics})
            result = episode(task, seed, {})
            assert not result.success
            assert result.row["lift_height_m"] < 0.005
            reasons.add(result.failure_reason)
    assert reasons <= {"no_contact", "dropped", "lift_below_threshold"}, reasons


def test_unstable_physics_is_sim_unstable_not_a_crash(cube: Path) -> None:
    physics = {"timestep": 0.05, "integrator": "euler", "solver_iterations": 1}
    task = make_task("fr3", "left", cube, physics=physics, control_dt=0.05)
    result = episode(task, 0, {})
    assert result.failure_reason == "sim_unstable"
    assert "diverged" in result.row["error_message"] or "MuJoCo" in result.row["error_message"]


def test_a_broken_grasp_file_is_an_error_row(tmp_path: Path) -> None:
    mesh = write_box(tmp_path, (0.04, 0.04, 0.04), "cube")
    np.save(tmp_path / "grasps.npy", np.zeros((5, 3), dtype=np.float32))
    task = make_task("fr3", "left", mesh)
    result = episode(task, 0, {})
    assert result.failure_reason == "error"
    assert "grasps.npy" in result.row["error_message"]


# --------------------------------------------------------------------------------------------
# Rows, determinism, traces


def test_row_matches_the_schema_and_is_deterministic(cube: Path, cache: dict) -> None:
    task = make_task("fr3", "left", cube)
    point = {"pick.pre_grasp_offset": 0.05}
    task = apply_overrides(task, point)
    first = episode(task, 4, cache, point=point, point_id=3, run="r").row
    second = episode(task, 4, cache, point=point, point_id=3, run="r").row
    fixed = set(SCHEMA) - ADDED_BY_EXECUTORS
    assert fixed <= set(first)
    assert {k for k in first if k not in SCHEMA} == {"param.pick.pre_grasp_offset"}
    timing = {"wall_time_s", "ik_time_s", "plan_time_s"}
    for key in first:
        if key in timing:
            continue
        a, b = first[key], second[key]
        assert a == b or (a != a and b != b), key  # NaN == NaN for this purpose
    assert first["point_id"] == 3 and first["run"] == "r"
    assert first["failure_reason"] in ("", *FAILURE_REASONS)


def test_trace_holds_what_a_viewer_needs(cube: Path, cache: dict) -> None:
    task = make_task("fr3", "left", cube)
    result = episode(task, 5, cache)
    trace = result.trace
    n = len(trace.time)
    # The command list's rows (one per servo chunk), then the validity phase's.
    in_list = np.flatnonzero(~np.char.startswith(trace.phase.astype(str), "validity"))
    substeps = round(task.control_dt / 0.002)
    chunks = math.ceil(substeps * 0.002 / SERVO_CHUNK_S - 1e-9)  # servo chunks per step
    assert len(in_list) == chunks * result.row["sim_steps"] // round(task.control_dt / 0.002)
    assert trace.time[in_list[-1]] == pytest.approx(result.row["sim_time_s"])
    assert trace.validity is not None and len(trace.validity.tugs) >= 6
    assert trace.qpos.shape == (n, result.scene.model.nq)
    for name in ("tcp_pose", "ee_pose", "object_pose"):
        assert getattr(trace, name).shape == (n, 7)
    assert trace.finger_forces.shape == (n, 2) and trace.gripper_width.shape == (n,)
    assert len(trace.phase) == n
    statuses = set(trace.candidate_status.tolist())
    assert "chosen" in statuses
    chosen = trace.candidate_index[trace.candidate_status == "chosen"]
    assert chosen.tolist() == [result.row["chosen_index"]]
    assert trace.candidate_T_world_ee.shape == (len(trace.candidate_index), 4, 4)
    # The planned TCP path ends at the lift target's TCP; the executed one comes close.
    assert len(trace.planned_tcp) > 10
    assert np.linalg.norm(trace.planned_tcp[-1] - trace.tcp_pose[in_list[-1], :3]) < 0.02
    assert np.all(np.diff(trace.planned_time) >= 0)


def test_an_episode_without_its_trace_has_the_same_row(cube: Path, cache: dict) -> None:
    """``EpisodeSpec.trace`` False (the engines benchmark's planning workers) skips the viewers'
    trace and nothing else: the row is the one of the episode with its trace."""
    task = make_task("fr3", "left", cube)
    with_trace = episode(task, 5, cache)
    without = episode(task, 5, cache, trace=False)
    assert with_trace.trace is not None and without.trace is None
    timing = {"wall_time_s", "ik_time_s", "plan_time_s"}
    for key, value in with_trace.row.items():
        if key not in timing:
            other = without.row[key]
            assert value == other or (value != value and other != other), key
    assert set(without.row) == set(with_trace.row)


# --------------------------------------------------------------------------------------------
# harness run


def test_harness_run_writes_a_run_directory(tmp_path: Path, capsys) -> None:
    """Two episodes with an override: exit 0, episodes.csv in the sweep layout with the
    override as a parameter column, the success rate with its Wilson interval printed."""
    import pandas as pd

    from harness.cli import main

    out = tmp_path / "run"
    code = main(
        [
            "run",
            str(TASKS_DIR / "fr3.yaml"),
            "--episodes",
            "2",
            "--seed",
            "3",
            "--set",
            "pick.timing=ruckig",
            "--out",
            str(out),
            "--record",
            "none",
        ]
    )
    assert code == 0
    frame = pd.read_csv(out / "episodes.csv")
    assert len(frame) == 2
    assert set(frame["timing"]) == {"ruckig"}
    assert "param.pick.timing" in frame.columns
    assert (out / "sweep.yaml").is_file() and (out / "summary.csv").is_file()
    printed = capsys.readouterr().out
    assert "Wilson" in printed and "/2" in printed


# --------------------------------------------------------------------------------------------
# Reference semantics: timeline, draw order, command targets, forward test (docs/semantics.md)

CENTRE = {"placement": {"pos_range": [[0.05, 0.0, 0.0], [0.05, 0.0, 0.0]]}}


# The reference's planner files (docs/reference-pick-skill.md section 3, tests/reference_robots.py).
@pytest.mark.parametrize("robot", sorted(REFERENCE_PLANNER_FILES))
def test_pregrasp_column_matches_the_reference_r5a_rule(robot: str) -> None:
    """The harness backs off along ee_axis; the reference along column 0 for "r5a" planner files
    and column 2 otherwise. The two rules agree on all three robots."""
    approach = RobotModel.load(robot).convention.approach_index
    for planner_file in REFERENCE_PLANNER_FILES[robot]:
        assert approach == (0 if "r5a" in planner_file else 2)
    T_grasp = np.eye(4)
    T_pre, _, _ = command_targets(T_grasp, 0.05, approach, 0.0)
    assert np.allclose(T_pre[:3, 3], -0.05 * np.eye(3)[:, approach])


def test_command_targets_fixed_orientation_reference_and_strict() -> None:
    """fixed_orientation replaces the orientations only after the pre-grasp was computed from the
    candidate's own approach axis (reference, quirk 13); strict backs off along the fixed axis.
    The lift is the grasp moved up along base z in the grasp's orientation; offset 0 -> none."""
    c, s = math.cos(0.4), math.sin(0.4)
    T_grasp = np.eye(4)
    T_grasp[:3, :3] = [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]  # approach z tilted
    T_grasp[:3, 3] = [0.4, 0.1, 0.05]
    fixed = np.diag([1.0, -1.0, -1.0])  # straight down
    reference = Semantics.from_pick(PickConfig(semantics="reference"))
    strict = Semantics.from_pick(PickConfig(semantics="strict"))
    pre, grasp, lift = command_targets(
        T_grasp, 0.05, 2, 0.1, fixed, reference.pregrasp_along_fixed_axis
    )
    assert np.allclose(pre[:3, 3], T_grasp[:3, 3] - 0.05 * T_grasp[:3, 2])
    assert np.allclose(grasp[:3, 3], T_grasp[:3, 3])
    for T in (pre, grasp, lift):
        assert np.allclose(T[:3, :3], fixed)
    assert np.allclose(lift[:3, 3], T_grasp[:3, 3] + [0.0, 0.0, 0.1])
    pre, grasp, _ = command_targets(T_grasp, 0.05, 2, 0.1, fixed, strict.pregrasp_along_fixed_axis)
    assert np.allclose(pre[:3, 3], T_grasp[:3, 3] + [0.0, 0.0, 0.05])
    _, _, lift = command_targets(T_grasp, 0.05, 2, 0.0)
    assert lift is None


def test_reference_timeline_and_draw_order(cube: Path, cache: dict) -> None:
    """One reference step, obj_init_trans, 20 settle steps, selection, 10 warm-up steps,
    execution; one stream per purpose from the seed: reset, candidate draw, lift offset. A
    replay of the reset and the selection with the same seed gives the same lift reference,
    candidates and lift offset. (Validity off: the phase after the verdict steps on.)"""
    task = make_task("fr3", "left", cube, object=CENTRE, pick={"validity": False})
    result = episode(task, 7, cache)
    row, trace, scene = result.row, result.trace, result.scene
    assert result.success, row["error_message"]
    timestep = scene.model.opt.timestep
    settle = round(INIT_RECORD_TIME_S / timestep) + round(SETTLE_TIME_S / timestep)
    assert result.timings["settle_steps"] == settle
    assert result.timings["warmup_steps"] == round(WARMUP_TIME_S / timestep)
    physics_steps = settle + result.timings["warmup_steps"] + row["sim_steps"]
    assert scene.data.time == pytest.approx(physics_steps * timestep)
    final_z = trace.object_pose[-1, 2]

    streams = EpisodeStreams(7)
    state = scene.reset(
        task, streams.scene(), settle_time=SETTLE_TIME_S, init_record_time=INIT_RECORD_TIME_S
    )
    assert row["lift_height_m"] == pytest.approx(final_z - state.object_init_position[2])
    T_world_obj = scene.T_world_object("target")
    assert np.allclose(T_world_obj, trace.T_world_object_start)
    bundle = get_scene(task, cache)
    poses = bundle.poses(task, grasp_file_for(task, scene))
    T_base_obj = invert_T(scene.T_world_base("left")) @ T_world_obj
    selection = select_candidates(
        poses, scene.robot.convention, task.pick, T_base_obj, streams.candidates(),
        Semantics.from_pick(task.pick).candidates,
    )  # fmt: skip
    assert len(selection.order) == 20 and selection.order.outcome == "ok"
    assert row["chosen_index"] in selection.order.indices.tolist()
    lift_offset = streams.lift().uniform(
        task.pick.post_grasp_offset_min, task.pick.post_grasp_offset_max
    )
    assert row["post_grasp_offset"] == lift_offset


@pytest.mark.parametrize("semantics", ["reference", "strict"])
def test_forward_test_and_the_lift(cube: Path, cache: dict, semantics: str) -> None:
    """A lift of 1 m is out of the FR3's reach. Reference: the forward test plans only the
    pre-grasp and the grasp (pick.py), so the first candidate passes and its lift, planned
    afterwards, fails the episode (plan_failed). Strict tests the lift too: every candidate
    fails there and it stops (no_feasible_candidate)."""
    lift = {"post_grasp_offset_min": 1.0, "post_grasp_offset_max": 1.0}
    pick = {"test_mode": "forward", "semantics": semantics, **lift}
    task = make_task("fr3", "left", cube, object=CENTRE, pick=pick)
    row = episode(task, 0, cache).row
    if semantics == "strict":
        assert row["failure_reason"] == "no_feasible_candidate"
        assert row["n_tested"] == 20 and row["n_feasible"] == 0
        assert "last: lift: " in row["error_message"]
    else:
        assert row["failure_reason"] == "plan_failed"
        assert row["error_message"].startswith("lift: ")
        assert row["n_tested"] == 1 and row["n_feasible"] == 1


def test_lift2_picks_with_the_lift_held_at_its_home(cache: dict) -> None:
    """The reference's Lift-2 planner moves the arm alone, the lift held at its home (0.46);
    so does the episode (seed 3 raised the lift 16 cm when the IK could use it)."""
    task = load_task(TASKS_DIR / "lift2_left.yaml")
    result = episode(task, 3, cache)
    check_pick(result)
    trace = result.trace
    assert trace.joint_names[0] == "lift_joint"
    assert np.max(np.abs(trace.q[:, 0] - 0.46)) < 2e-3  # servo sag only
