"""Lanes (harness.engines.mjwarp.lanes, mjwarp_stream) on Warp's CPU device: jobs run one after
another in a fixed set of worlds give the lockstep motion's rows and outcomes bit for bit.
Skipped without the 'gpu' extra (as tests/test_engines.py)."""

from __future__ import annotations

import dataclasses
import importlib.util
from collections.abc import Hashable

import numpy as np
import pytest
from helpers import device_jobs, fr3_device_jobs, same_fields

HAS_WARP = importlib.util.find_spec("mujoco_warp") is not None
needs_warp = pytest.mark.skipif(not HAS_WARP, reason="needs the 'gpu' extra (pip install .[gpu])")


@pytest.mark.slow
@pytest.mark.gpu
@needs_warp
@pytest.mark.parametrize("ahead", [False, True])
def test_jobs_through_two_lanes_keep_the_lockstep_rows(ahead: bool) -> None:
    """Four jobs (FR3 cube seed 0's cut to 10, 4, 7 and 5 control steps, a window of 3)
    through two lanes, each free lane taking the next job between replays of one control
    step: every job's signal rows, warm-up row and saved window states equal the lockstep
    batch's bit for bit, and a lane idles less than one replay per job; ``ahead`` (each
    replay queued before the last is collected: ``queue`` / ``settle``), less than two."""
    import mujoco_warp as mjw

    from harness.benchmarks.engines import _SCENES
    from harness.engines.mjwarp.engine import MjwarpEngine
    from harness.engines.mjwarp.lanes import LaneRun
    from harness.engines.mjwarp.motion import MotionRun
    from harness.engines.mjwarp.retirement import segments
    from harness.engines.mjwarp.steps import SMALL, BatchTimings
    from harness.episode.scene_cache import get_scene

    (job,) = fr3_device_jobs(1)
    task = job.task
    cuts = (10, 4, 7, 5)
    jobs = [
        dataclasses.replace(
            job, schedule=dataclasses.replace(job.schedule, ctrl=job.schedule.ctrl[:k])
        )
        for k in cuts
    ]
    window = 3
    spans = np.array(cuts) + window
    dm = MjwarpEngine("cpu").batch(get_scene(task, _SCENES).scene, task).dm

    def make(k: int) -> object:
        return mjw.put_data(
            dm.mj_model, dm.template, nworld=k, nconmax=SMALL.nconmax, njmax=SMALL.njmax
        )

    lock = MotionRun(dm, jobs, spans, window, make)
    assert lock.run(segments(spans, 0.0, 1), SMALL, BatchTimings(), lambda: None) == []
    lock_out, lock_warm = lock.out.numpy(), lock.warm.numpy()[:, 0]
    lock_saved = [a.numpy() for a in lock.saved]

    chunks = job.schedule.chunk_sizes
    lanes = LaneRun(dm, 2, 4, 16, window, chunks, SMALL, make, interval=sum(chunks))
    timings = BatchTimings()
    waiting = list(range(len(jobs)))
    rows: dict[int, np.ndarray] = {}
    warm: dict[int, np.ndarray] = {}
    replays = 0
    while waiting or lanes.busy or lanes.in_flight:
        free = lanes.free_lanes()[: len(waiting)]
        if len(free):
            take, waiting = waiting[: len(free)], waiting[len(free) :]
            lanes.load(free, np.array(take), [jobs[i] for i in take], spans[take])
        if ahead:
            replays += lanes.queue(timings, lambda graph: None)
            finished = lanes.settle(timings, lambda mark: None, lambda: None)
        else:
            lanes.launch(timings)
            replays += 1
            finished = lanes.collect(timings)
        assert not any(finished.overflowed)
        for slot, r, w in zip(finished.slots, finished.rows, finished.warm, strict=True):
            rows[slot], warm[slot] = r, w
        lanes.release(finished.slots)
    assert sorted(rows) == [0, 1, 2, 3]
    for i, span in enumerate(spans):
        assert rows[i].shape[0] == span
        np.testing.assert_array_equal(rows[i], lock_out[i, :span])
        np.testing.assert_array_equal(warm[i], lock_warm[i])
        for lane_saved, lock_array in zip(lanes.saved, lock_saved, strict=True):
            np.testing.assert_array_equal(lane_saved.numpy()[i], lock_array[i])
    # each job's own physics steps, and at most one replay (ahead: two) of idling per job and
    # lane
    substeps = sum(chunks)
    assert timings.span_steps == sum(job.schedule.warmup_steps + s * substeps for s in spans)
    idle = (2 if ahead else 1) * (len(jobs) + 2) * substeps
    assert timings.motion_steps <= timings.span_steps + idle
    assert replays * substeps * 2 == timings.motion_steps


@pytest.mark.slow
@pytest.mark.gpu
@needs_warp
@pytest.mark.parametrize(("ahead", "tug_lanes"), [("0", "1"), ("0", "0"), ("1", "1")])
def test_a_stream_of_jobs_judges_as_the_lockstep_batch(
    ahead: str, tug_lanes: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Three whole FR3 cube episodes (seeds 0-2) handed over in two installments to a stream
    of two lanes: each outcome (the verdict, its measures, the validity phase with its tug
    ladder) equals the lockstep batch's, field by field, with the tug's rungs in the lanes
    (``HARNESS_TUG_LANES=1``) or in rounds beside them (the default: tug groups of two jobs),
    and with each replay collected before the next or (``HARNESS_LANE_AHEAD=1``, whose tug
    runs beside) after it is queued."""
    from harness.benchmarks.engines import _SCENES
    from harness.engines.mjwarp.engine import MjwarpEngine
    from harness.engines.mjwarp.stream import LaneStream
    from harness.episode.scene_cache import get_scene

    jobs = fr3_device_jobs(3)
    assert len(jobs) == 3
    task = jobs[0].task
    engine = MjwarpEngine("cpu")
    scene = get_scene(task, _SCENES).scene
    lockstep = engine.batch(scene, task).run(jobs)
    installments: list[list[tuple[Hashable, object]] | None] = [
        [("a", jobs[0]), ("b", jobs[1])],
        [("c", jobs[2])],
        None,
    ]
    monkeypatch.setenv("HARNESS_LANE_AHEAD", ahead)
    monkeypatch.setenv("HARNESS_TUG_LANES", tug_lanes)
    stream = LaneStream(engine.batch(scene, task), nlane=2, group=2)
    assert stream.ahead == (ahead == "1")
    in_lanes = ahead == "0" and tug_lanes == "1"
    outcomes = stream.run(lambda block, want: installments.pop(0))  # type: ignore[arg-type,return-value]
    assert sorted(outcomes) == ["a", "b", "c"]
    for key, expected in zip("abc", lockstep, strict=True):
        assert same_fields(outcomes[key], expected), key
    assert (stream.ladders is not None) == in_lanes
    t = stream.timings
    assert t.tug_rounds >= 2 and t.reruns == 0
    # in the lanes: every rung is a lane's (no batch beside them, no time of its own), and
    # the rung-steps count as busy lane-steps
    assert (t.tug_s == 0.0) == in_lanes and t.tug_rungs >= 6
    assert ("tug in the lanes: " in stream.summary()) == in_lanes
    if in_lanes:
        assert t.world_steps == t.motion_steps and t.span_steps <= t.motion_steps
    # every host visit replayed one interval of every lane; the launch and the wait are parts
    # of the visits' wall time, and the stream's line reports them
    assert stream.lanes is not None
    replays = t.motion_steps // (2 * stream.lanes.interval)
    assert t.visits > 0 and t.motion_steps == replays * 2 * stream.lanes.interval
    assert t.visits == replays if ahead == "0" else t.visits >= replays  # ahead: + the last
    assert 0 < t.launch_s + t.wait_s <= t.physics_s
    assert f"{t.motion_steps // 2:,} physics steps in {t.visits} visits" in stream.summary()
    assert (
        len(stream.trace) == t.visits and "by tenths, busy/queued/free slots: " in stream.summary()
    )
    assert max(busy for _, busy, _, _ in stream.trace) <= 2  # two lanes
    assert any(o.validity is not None and o.validity.measure.robustness_g > 0 for o in lockstep)


@pytest.mark.slow
@pytest.mark.gpu
@needs_warp
def test_one_stream_serves_both_arms_of_a_scene() -> None:
    """Lift-2's left and right cube picks share a stream key, so one stream of two lanes runs
    them mixed: each outcome equals its own arm's lockstep batch field by field, and the right
    arm's successful grasps were held by the right gripper's fingers (a world reading another
    arm's fingers would see no force and drop the verdict). Split ALOHA's two arms do not
    share one: its right-arm task lets the robot touch the table (another model)."""
    from harness.benchmarks.engines import _SCENES
    from harness.engines.mjwarp.devices import stream_key
    from harness.engines.mjwarp.engine import MjwarpEngine
    from harness.engines.mjwarp.stream import LaneStream
    from harness.episode.scene_cache import get_scene

    left, right = device_jobs("lift2_left", 4)[:1], device_jobs("lift2_right", 8)[:2]
    assert left and len(right) == 2
    assert stream_key(left[0]) == stream_key(right[0])
    aloha = [device_jobs(f"split_aloha_{arm}", 4)[:1] for arm in ("left", "right")]
    assert all(aloha) and stream_key(aloha[0][0]) != stream_key(aloha[1][0])
    engine = MjwarpEngine("cpu")
    scene = get_scene(left[0].task, _SCENES).scene
    assert get_scene(right[0].task, _SCENES).scene is scene
    expected = engine.batch(scene, left[0].task).run(left)
    expected += engine.batch(scene, right[0].task).run(right)
    assert engine.batch(scene, left[0].task).dm is engine.batch(scene, right[0].task).dm
    mixed: list[tuple[Hashable, object]] = [("r0", right[0]), ("l0", left[0]), ("r1", right[1])]
    installments: list[list[tuple[Hashable, object]] | None] = [mixed, None]
    stream = LaneStream(engine.batch(scene, right[0].task), nlane=2, group=2)
    outcomes = stream.run(lambda block, want: installments.pop(0))  # type: ignore[arg-type,return-value]
    for key, want in zip(("l0", "r0", "r1"), expected, strict=True):
        assert same_fields(outcomes[key], want), key
    held = [o for o in expected[1:] if o.success]
    assert held, "no right-arm success to check the fingers of"
    for outcome in held:
        assert min(outcome.finger_force_left_n, outcome.finger_force_right_n) > 0.0


@pytest.mark.slow
@pytest.mark.gpu
@pytest.mark.skipif(not HAS_WARP, reason="needs the 'gpu' extra (pip install .[gpu])")
def test_a_job_too_long_for_a_lane_is_answered_before_the_stream_ends(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A product stream ends only when its run does, after every answer: a job whose span
    exceeds the lanes' rows (here: every job, ``LANE_ROWS`` cut to 16) runs as a lockstep
    batch once the lanes are idle, and its outcome is the lockstep batch's."""
    from harness.benchmarks.engines import _SCENES
    from harness.engines.mjwarp import stream as stream_module
    from harness.engines.mjwarp.engine import MjwarpEngine
    from harness.episode.scene_cache import get_scene

    jobs = fr3_device_jobs(1)
    task = jobs[0].task
    engine = MjwarpEngine("cpu")
    scene = get_scene(task, _SCENES).scene
    lockstep = engine.batch(scene, task).run(jobs)
    monkeypatch.setattr(stream_module, "LANE_ROWS", 16)
    answered: dict[Hashable, object] = {}
    given = [[("a", jobs[0])]]

    def source(block: bool, want: int) -> list[tuple[Hashable, object]] | None:
        if given:
            return given.pop()  # type: ignore[return-value]
        return None if "a" in answered else []  # like a sweep: no end before the answer

    stream = stream_module.LaneStream(
        engine.batch(scene, task), nlane=2, group=2,
        on_outcome=lambda key, outcome: answered.__setitem__(key, outcome),
    )  # fmt: skip
    stream.run(source)  # type: ignore[arg-type]
    assert same_fields(answered["a"], lockstep[0])


@pytest.mark.gpu
@needs_warp
def test_host_visits_follow_the_lane_interval_setting(monkeypatch: pytest.MonkeyPatch) -> None:
    """A stream's lanes replay ``INTERVAL_CONTROL_STEPS`` control steps between host visits,
    or ``HARNESS_LANE_INTERVAL`` of them when set (in physics steps: times the servo chunks)."""
    from types import SimpleNamespace

    from harness.engines.mjwarp import stream as stream_module

    job = fr3_device_jobs(1)[0]
    made: list[int] = []
    monkeypatch.setattr(stream_module, "LaneRun", lambda *args, **kw: made.append(args[-1]))
    batch = SimpleNamespace(dm=None, buffers=None, timings=None, data=lambda n, b: None)
    substeps = sum(job.schedule.chunk_sizes)
    stream = stream_module.LaneStream(batch, nlane=2)  # type: ignore[arg-type]
    monkeypatch.delenv("HARNESS_LANE_INTERVAL", raising=False)
    stream._make(job)
    monkeypatch.setenv("HARNESS_LANE_INTERVAL", "32")
    stream._make(job)
    assert made == [stream_module.INTERVAL_CONTROL_STEPS * substeps, 32 * substeps]


@pytest.mark.gpu
@needs_warp
def test_a_stream_takes_the_jobs_it_has_room_for() -> None:
    """What a stream asks its source for: its free lanes and a quarter of its lanes in reserve,
    less the jobs already waiting in it (the rest stay where another device can take them)."""
    from collections import deque
    from types import SimpleNamespace

    from harness.engines.mjwarp import stream as stream_module

    batch = SimpleNamespace(dm=None, buffers=None, timings=None, data=lambda n, b: None)
    stream = stream_module.LaneStream(batch, nlane=64)  # type: ignore[arg-type]
    assert stream._room(deque()) == 64 + 16
    assert stream._room(deque([("a", None)] * 70)) == 10
    assert stream._room(deque([("a", None)] * 90)) == 0
    lane_job = np.full(64, 3)
    lane_job[:5] = -1  # five free lanes
    stream.lanes = SimpleNamespace(free_lanes=lambda: np.flatnonzero(lane_job < 0))  # type: ignore[assignment]
    assert stream._room(deque([("a", None)] * 4)) == 5 + 16 - 4


@pytest.mark.slow
@pytest.mark.gpu
@needs_warp
def test_harness_compile_warms_a_task_models_lockstep_batch_and_lanes() -> None:
    """``harness compile`` (``harness.runs.warm.warm``) runs a task model's job as a lockstep
    batch and through a one-lane stream on each device, saying each model as it starts and
    when it is ready (the stream's source is asked as every stream asks it)."""
    from harness.runs.warm import warm

    job = fr3_device_jobs(1)[0]
    said: list[str] = []
    spent = warm([job], ["cpu"], said.append)
    name = "fr3 cube on cpu"
    assert list(spent) == [name] and spent[name] > 0
    assert said[0].startswith(f"[1/1] {name}: compiling") and "ready in" in said[-1]
