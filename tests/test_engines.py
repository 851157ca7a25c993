"""Execution engines (harness.engines): the protocol, the schedule, and the mjwarp engine on
Warp's CPU device (skipped without the 'gpu' extra: CI installs the extra only for pyright,
because Warp compiles MuJoCo Warp's kernels for the CPU on first use, several minutes there)."""

from __future__ import annotations

import dataclasses
import importlib.util
import math

import numpy as np
import pytest
from helpers import same_fields

from harness.config import load_task
from harness.engines import ENGINE_NAMES, engine_for, register_engine
from harness.engines.mjwarp.signals import (
    OBJ_MAT,
    OBJ_POS,
    SIGNALS,
    TCP_MAT,
    TCP_POS,
    HoldWindow,
    hold_window,
    object_pose_in_tcp,
    rest_steps,
)
from harness.episode import EpisodeSpec, run_episode
from harness.errors import HarnessError
from harness.objects.assets import repo_root
from harness.pick.validity import REST_SPEED, pose_drift
from harness.transforms import invert_T

HAS_WARP = importlib.util.find_spec("mujoco_warp") is not None


def fr3():
    return load_task(repo_root() / "tasks" / "pick" / "fr3.yaml")


def test_unknown_engine_is_one_clear_error() -> None:
    assert ENGINE_NAMES == ("mujoco", "mjwarp")
    with pytest.raises(HarnessError, match="unknown engine 'physx'"):
        engine_for("physx")


def test_hold_window_follows_the_cpu_rest_rule() -> None:
    """The hold starts at the first row whose object speed is under REST_SPEED, at most
    rest_steps rows after the motion; it lasts ceil(hold_time / dt) rows."""
    dt = 1 / 30
    steps = np.zeros((200, SIGNALS))
    motion = 50
    steps[motion - 1 : motion + 3, 5] = 2 * REST_SPEED  # moving for 4 rows after the motion
    window = hold_window(steps, motion, hold_time=0.5, dt=dt)
    assert window == HoldWindow(motion + 3, motion + 3 + 15)
    steps[:, 5] = 1.0  # never at rest: the wait ends after REST_WAIT_S
    assert hold_window(steps, motion, 0.5, dt).rest_end == motion - 1 + rest_steps(dt)


def _rot_z(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def test_object_pose_in_tcp_is_the_executors_relative_pose() -> None:
    """A signal row's object pose in the TCP frame is inv(T_world_tcp) @ T_world_object (what
    PickExecutor.object_pose_in_tcp computes), so the slip's drift reads the same on both
    engines: a 0.2 rad turn of the object about the TCP's z and 3 mm along it."""
    T_tcp, T_obj = np.eye(4), np.eye(4)
    T_tcp[:3, :3], T_tcp[:3, 3] = _rot_z(0.7), (0.4, -0.1, 0.3)
    T_obj[:3, :3], T_obj[:3, 3] = _rot_z(0.9), (0.45, -0.05, 0.28)
    row = np.zeros(SIGNALS)
    row[TCP_POS], row[TCP_MAT] = T_tcp[:3, 3], T_tcp[:3, :3].reshape(-1)
    row[OBJ_POS], row[OBJ_MAT] = T_obj[:3, 3], T_obj[:3, :3].reshape(-1)
    closed = object_pose_in_tcp(row)
    np.testing.assert_allclose(closed, invert_T(T_tcp) @ T_obj, atol=1e-12)
    row[OBJ_MAT] = (_rot_z(1.1)).reshape(-1)
    row[OBJ_POS] = T_obj[:3, 3] + 0.003 * T_tcp[:3, 2]
    slip, turn = pose_drift(closed, object_pose_in_tcp(row))
    assert math.isclose(slip, 0.003, rel_tol=1e-9) and math.isclose(turn, 0.2, rel_tol=1e-9)


class _Keep:
    name = "keep"

    def __init__(self) -> None:
        self.jobs: list = []

    def execute(self, job):
        from harness.engines.mjwarp.schedule import device_job

        self.jobs.append(device_job(job))
        return engine_for("mujoco").execute(job)


def test_schedule_marks_the_closing_and_the_verdict() -> None:
    """The kinematic schedule of an FR3 pick: closing before the verdict, one control row per
    step of the CPU run up to a few steps (the commanded pose leads the real arm), the
    controls held at the end; the mujoco engine's row is unchanged by making it."""
    keep = _Keep()
    register_engine(keep)
    cache: dict = {}
    spec = EpisodeSpec(task=fr3(), seed=0)
    row = run_episode(dataclasses.replace(spec, engine="keep"), cache).row
    plain = run_episode(spec, cache).row
    assert row["success"] and plain["success"]
    assert row["lift_height_m"] == plain["lift_height_m"]
    (job,) = keep.jobs
    schedule = job.schedule
    assert 0 < schedule.close_step < schedule.verdict_step < schedule.steps
    cpu_steps = plain["sim_steps"] // sum(schedule.chunk_sizes)
    assert abs((schedule.verdict_step + 1) - cpu_steps) <= 10
    assert schedule.ctrl.shape[1:] == (len(schedule.chunk_sizes), len(job.state["ctrl"]))
    np.testing.assert_array_equal(schedule.hold_ctrl, schedule.ctrl[-1, -1])


class _BothSchedules:
    """Makes each job's schedule lean and in full (every measurement of the executor), then
    runs it on the mujoco engine."""

    name = "both-schedules"

    def __init__(self) -> None:
        self.pairs: list = []

    def execute(self, job):
        from harness.engines.mjwarp.schedule import build_schedule

        self.pairs.append((build_schedule(job, lean=False), build_schedule(job)))
        return engine_for("mujoco").execute(job)


@pytest.mark.parametrize(("arm", "seed"), [("fr3", 0), ("split_aloha_left", 3)])
def test_the_lean_schedule_is_the_full_runs(arm: str, seed: int) -> None:
    """The kinematic run without the penetration, the speeds and the per-chunk kinematics makes
    the same schedule, byte for byte: controls, chunks, warm-up, closing and verdict steps."""
    both = _BothSchedules()
    register_engine(both)
    task = load_task(repo_root() / "tasks" / "pick" / f"{arm}.yaml")
    row = run_episode(EpisodeSpec(task=task, seed=seed, engine=both.name), {}).row
    assert row["success"], row["error_message"]
    (pair,) = both.pairs
    full, lean = pair
    assert 0 < full.close_step < full.verdict_step < full.steps
    for field in dataclasses.fields(full):
        a, b = getattr(full, field.name), getattr(lean, field.name)
        if isinstance(a, np.ndarray):
            assert a.dtype == b.dtype and a.shape == b.shape, field.name
            assert a.tobytes() == b.tobytes(), field.name
        else:
            assert a == b, field.name


@pytest.mark.slow
@pytest.mark.gpu
@pytest.mark.skipif(not HAS_WARP, reason="needs the 'gpu' extra (pip install .[gpu])")
def test_mjwarp_on_the_cpu_device_agrees_with_mujoco(monkeypatch: pytest.MonkeyPatch) -> None:
    """One FR3 cube pick on both engines (MJWarp on Warp's CPU device): the same row schema,
    the same reference and validity verdicts, close measurements."""
    monkeypatch.setenv("HARNESS_WARP_DEVICE", "cpu")
    cache: dict = {}
    spec = EpisodeSpec(task=fr3(), seed=0)
    cpu = run_episode(spec, cache).row
    gpu = run_episode(dataclasses.replace(spec, engine="mjwarp"), cache).row
    assert list(gpu) == list(cpu)
    assert (cpu["engine"], gpu["engine"]) == ("mujoco", "mjwarp")
    for key in ("success", "failure_reason", "valid", "invalid_reason", "robustness_g"):
        assert gpu[key] == cpu[key], key
    assert gpu["success"] and gpu["valid"]
    for key in ("finger_force_left_n", "finger_force_right_n"):
        assert math.isclose(gpu[key], cpu[key], rel_tol=0.2), key
    assert gpu["lift_height_m"] > 0.1 and gpu["tcp_grasp_error_m"] < 2e-3
    assert abs(gpu["sim_steps"] - cpu["sim_steps"]) <= 10 * 17
    # the issue-22 verdict inputs: drift in the hand from the closing, depth in the slab
    assert abs(gpu["hold_slip_m"] - cpu["hold_slip_m"]) < 1e-3
    assert abs(gpu["hold_rotation_rad"] - cpu["hold_rotation_rad"]) < math.radians(1.0)
    assert gpu["table_penetration_m"] >= 0.0
    assert abs(gpu["table_penetration_m"] - cpu["table_penetration_m"]) < 1e-3


@pytest.mark.slow
@pytest.mark.gpu
@pytest.mark.skipif(not HAS_WARP, reason="needs the 'gpu' extra (pip install .[gpu])")
def test_mjwarp_tug_rounds_give_the_24_rung_ladder() -> None:
    """A grasp that gives way (FR3, 0.4 kg cube at friction 0.3, seed 14: it survives no rung
    on the CPU) on Warp's CPU device: the tug in rounds (the default policy) and all 24 rungs
    in one round give the same robustness, tug message and validity; the rounds run fewer
    rung-worlds than 24 only where the ladder stops early, never more."""
    from harness.benchmarks.engines import _SCENES, _plan, tasks
    from harness.config import apply_overrides
    from harness.engines.mjwarp.batch import WorldBatch
    from harness.engines.mjwarp.engine import MjwarpEngine
    from harness.engines.mjwarp.tug import RoundPolicy
    from harness.episode import EpisodeSpec
    from harness.episode.scene_cache import get_scene
    from harness.runs.expansion import point_overrides

    (task,) = tasks(("fr3",), ("cube",))
    task = apply_overrides(
        task, point_overrides(task, {"object.mass": 0.4, "object.friction": 0.3})
    )
    _, job = _plan(EpisodeSpec(task=task, seed=14))
    assert job is not None
    engine = MjwarpEngine("cpu")
    rounds = engine.batch(get_scene(task, _SCENES).scene, task)
    full = WorldBatch(rounds.dm, RoundPolicy.ALL)
    (a,) = rounds.run([job])
    (b,) = full.run([job])
    assert a.validity is not None and b.validity is not None
    assert (full.timings.tug_rounds, full.timings.tug_rungs) == (1, 24)
    assert rounds.timings.tug_rounds >= 2 and rounds.timings.tug_rungs <= 24
    for key in ("robustness_g", "tug_message"):
        assert getattr(a.validity.measure, key) == getattr(b.validity.measure, key), key
    assert (a.validity.valid, a.validity.invalid_reason) == (
        b.validity.valid,
        b.validity.invalid_reason,
    )


@pytest.mark.slow
@pytest.mark.gpu
@pytest.mark.skipif(not HAS_WARP, reason="needs the 'gpu' extra (pip install .[gpu])")
def test_a_world_whose_rows_do_not_fit_runs_again_with_the_large_buffers(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """FR3 cube seed 0 on Warp's CPU device with room only for the rows of the scene's current
    state (MJWarp's least; the settled cube, no grasp: a grasp asks for ~80): the overflow is
    seen, the world runs again with ``LARGE`` and its outcome is the one ``LARGE`` gives
    directly; when ``LARGE`` is too small as well the episode ends
    ``sim_unstable`` naming the full buffer, never as a silently wrong verdict."""
    from harness.benchmarks.engines import _SCENES, _plan
    from harness.engines.mjwarp import batch as mjwarp_batch
    from harness.engines.mjwarp.batch import LARGE, Buffers, WorldBatch
    from harness.engines.mjwarp.engine import MjwarpEngine
    from harness.episode.scene_cache import get_scene

    task = fr3()
    _, job = _plan(EpisodeSpec(task=task, seed=0))
    assert job is not None
    dm = MjwarpEngine("cpu").batch(get_scene(task, _SCENES).scene, task).dm
    tiny = Buffers(nconmax=64, njmax=max(1, int(dm.template.nefc)))
    retried = WorldBatch(dm, buffers=tiny)
    direct = WorldBatch(dm, buffers=LARGE)
    (a,) = retried.run([job])
    (b,) = direct.run([job])
    assert retried.timings.reruns == 1 and direct.timings.reruns == 0
    assert tiny.njmax < direct.timings.peak_rows <= LARGE.njmax
    assert a.success and same_fields(a, b)
    monkeypatch.setattr(mjwarp_batch, "LARGE", tiny)
    (c,) = WorldBatch(dm, buffers=tiny).run([job])
    assert c.failure_reason == "sim_unstable"
    assert "constraint buffer was full" in c.message


@pytest.mark.slow
@pytest.mark.gpu
@pytest.mark.skipif(not HAS_WARP, reason="needs the 'gpu' extra (pip install .[gpu])")
def test_worlds_that_leave_the_motion_early_keep_the_lockstep_rows() -> None:
    """Three worlds (FR3 cube seed 0's job cut to 10, 4 and 7 control steps, a validity window
    of 3) on Warp's CPU device, once in lockstep and once in segments (each world leaves at the
    end of its span, the others carried into a smaller data): each world's signal rows over its
    span, its warm-up row and its saved window states are the same bit for bit, and the
    segments step no world past its span."""
    import mujoco_warp as mjw

    from harness.benchmarks.engines import _SCENES, _plan
    from harness.engines.mjwarp.engine import MjwarpEngine
    from harness.engines.mjwarp.motion import MotionRun
    from harness.engines.mjwarp.retirement import segments
    from harness.engines.mjwarp.steps import SMALL, BatchTimings
    from harness.episode.scene_cache import get_scene

    task = fr3()
    _, job = _plan(EpisodeSpec(task=task, seed=0))
    assert job is not None
    jobs = [
        dataclasses.replace(
            job, schedule=dataclasses.replace(job.schedule, ctrl=job.schedule.ctrl[:k])
        )
        for k in (10, 4, 7)
    ]
    window = 3
    spans = np.array([10, 4, 7]) + window
    dm = MjwarpEngine("cpu").batch(get_scene(task, _SCENES).scene, task).dm

    def make(k: int) -> object:
        return mjw.put_data(
            dm.mj_model, dm.template, nworld=k, nconmax=SMALL.nconmax, njmax=SMALL.njmax
        )

    results = []
    for retire in (0.0, 0.3):
        plan = segments(spans, retire, min_worlds=1)
        timings = BatchTimings()
        run = MotionRun(dm, jobs, spans, window, make)
        assert run.run(plan, SMALL, timings, lambda: None) == []
        results.append((plan, timings, run.out.numpy(), run.warm.numpy(), run.saved))
    (lock_plan, lock_t, lock_out, lock_warm, lock_saved) = results[0]
    (seg_plan, seg_t, seg_out, seg_warm, seg_saved) = results[1]
    assert [s.end for s in lock_plan] == [13] and [s.end for s in seg_plan] == [7, 10, 13]
    for w, span in enumerate(spans):
        np.testing.assert_array_equal(seg_out[w, :span], lock_out[w, :span])
        assert not np.any(seg_out[w, span:])  # a world that left records nothing after
    np.testing.assert_array_equal(seg_warm, lock_warm)
    for a, b in zip(seg_saved, lock_saved, strict=True):
        np.testing.assert_array_equal(a.numpy(), b.numpy())
    # here every world leaves at the end of its own span: no padding at all
    assert seg_t.motion_steps == seg_t.span_steps == lock_t.span_steps < lock_t.motion_steps
