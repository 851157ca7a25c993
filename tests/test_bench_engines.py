"""The engines bench's GPU path without a GPU: planning overlapped with device batches (the
device's ``execute_many`` is a stub here; the real one is measured on the GPU box)."""

from __future__ import annotations

import importlib.util
import threading
import time
from typing import Any, ClassVar

import pytest

from harness.benchmarks import engines as bench
from harness.engines.mjwarp import engine as mjwarp_engine
from harness.pick.outcome import PickOutcome


class _Timings:
    upload_s = physics_s = tug_s = download_s = judge_s = peak_contacts = 0.0
    world_steps = motion_steps = span_steps = tug_rounds = tug_rungs = reruns = peak_rows = 0


_COUNT = threading.Lock()
HAS_WARP = importlib.util.find_spec("mujoco_warp") is not None


class _StubEngine:
    batches: ClassVar[list[int]] = []
    lengths: ClassVar[list[list[int]]] = []
    slots_seen: ClassVar[list[Any]] = []
    # set by a test: every timed batch waits here for the other slot's batch
    barrier: ClassVar[threading.Barrier | None] = None
    # set by a test: each batch takes this long, and the most batches at once are counted
    delay_s: ClassVar[float] = 0.0
    running: ClassVar[int] = 0
    most_running: ClassVar[int] = 0

    def __init__(self, device: str | None = None, buffers: Any = None, retire: Any = None) -> None:
        self.device = device

    def slots(self, count: int) -> list[Any]:
        prefix = "" if self.device in (None, "stub") else f"{self.device} "
        return [f"{prefix}slot {k}" for k in range(count)]

    def memory_high_gb(self) -> float:
        return 0.0

    def execute_many(
        self, scene: Any, jobs: list[Any], slot: Any = None
    ) -> tuple[list[PickOutcome], Any]:
        barrier = _StubEngine.barrier
        if slot is not None and barrier is not None and barrier.n_waiting + 1 <= barrier.parties:
            _StubEngine.barrier = None if barrier.n_waiting + 1 == barrier.parties else barrier
            barrier.wait(timeout=60)  # the first two timed batches are on the device at once
        with _COUNT:
            _StubEngine.running += 1
            _StubEngine.most_running = max(_StubEngine.most_running, _StubEngine.running)
        time.sleep(_StubEngine.delay_s)
        with _COUNT:
            _StubEngine.running -= 1
        _StubEngine.slots_seen.append(slot)
        _StubEngine.batches.append(len(jobs))
        _StubEngine.lengths.append([job.schedule.steps for job in jobs])
        timings = _Timings()
        timings.world_steps = len(jobs)
        return [PickOutcome(success=True, message="stub") for _ in jobs], timings


def test_planned_jobs_are_stepped_in_batches_while_the_pool_plans(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(mjwarp_engine, "MjwarpEngine", _StubEngine)
    monkeypatch.setenv("BENCH_SLOTS", "1")  # one batch at a time: their order is checked
    _StubEngine.batches, _StubEngine.lengths, _StubEngine.barrier = [], [], None
    specs = bench.specs(bench.tasks(("fr3",), ("cube",)), 5)
    result = bench.run_gpu(specs, workers=2, device="stub", batch=2, chunk=2, bucket=2)
    executed = [i for i, (_, job) in enumerate(result["planned"]) if job is not None]
    assert sorted(result["outcomes"]) == executed and len(executed) >= 4
    warmup, *timed = _StubEngine.batches
    assert warmup == 1  # the task model's kernels load before the clock
    assert sum(timed) == len(executed) and max(timed) == 2
    assert result["batches"] == len(timed) and result["max_batch"] == 2
    assert 0.0 < result["plan_s"] <= result["total_s"]
    # bucket=2: one batch ran when 4 jobs waited (its 2 shortest schedules); the 1-3 left run
    # at the end, shortest first
    _, triggered, *flush = _StubEngine.lengths
    assert len(triggered) == 2
    flushed = [length for batch in flush for length in batch]
    assert flushed == sorted(flushed) and len(flushed) == len(executed) - 2


def test_two_slots_hold_two_batches_at_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """BENCH_SLOTS=2: two batches are on the device at the same time (the first two timed
    batches wait at a barrier for each other: run one at a time, the barrier would time out and
    the run fail), each on a slot of its own; every executed episode gets its outcome."""
    monkeypatch.setattr(mjwarp_engine, "MjwarpEngine", _StubEngine)
    monkeypatch.setenv("BENCH_SLOTS", "2")
    _StubEngine.batches, _StubEngine.lengths, _StubEngine.slots_seen = [], [], []
    _StubEngine.barrier = threading.Barrier(2)
    try:
        specs = bench.specs(bench.tasks(("fr3",), ("cube",)), 6)
        result = bench.run_gpu(specs, workers=2, device="stub", batch=2, chunk=6, bucket=1)
    finally:
        _StubEngine.barrier = None
    executed = [i for i, (_, job) in enumerate(result["planned"]) if job is not None]
    assert len(executed) >= 4 and sorted(result["outcomes"]) == executed
    assert result["slots"] == 2 and result["batches"] == -(-len(executed) // 2)
    assert set(_StubEngine.slots_seen[1:]) == {"slot 0", "slot 1"}
    assert 0.0 < result["device_s"] <= result["total_s"]


def test_two_devices_each_load_the_kernels_and_take_batches_in_turn(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """device "a,b": one engine per device, both load the task model before the clock, and
    the batches go to both devices' slots; every executed episode gets its outcome."""
    monkeypatch.setattr(mjwarp_engine, "MjwarpEngine", _StubEngine)
    monkeypatch.setenv("BENCH_SLOTS", "1")
    _StubEngine.batches, _StubEngine.lengths, _StubEngine.slots_seen = [], [], []
    _StubEngine.barrier = None
    specs = bench.specs(bench.tasks(("fr3",), ("cube",)), 6)
    result = bench.run_gpu(specs, workers=2, device="a,b", batch=2, chunk=6, bucket=1)
    executed = [i for i, (_, job) in enumerate(result["planned"]) if job is not None]
    assert sorted(result["outcomes"]) == executed and result["slots"] == 2
    loads, timed = _StubEngine.slots_seen[:2], _StubEngine.slots_seen[2:]
    assert loads == [None, None]  # each device's engine loaded the kernels, off the clock
    assert set(timed) == {"a slot 0", "b slot 0"}


def test_a_free_slot_takes_the_shortest_waiting_jobs(monkeypatch: pytest.MonkeyPatch) -> None:
    """min_batch: a batch runs as soon as the device has a free slot and min_batch jobs wait
    (never more batches at once than slots), each of at most `batch` jobs, the shortest
    waiting; what waits when planning ends runs shortest first."""
    monkeypatch.setattr(mjwarp_engine, "MjwarpEngine", _StubEngine)
    monkeypatch.setenv("BENCH_SLOTS", "1")
    _StubEngine.batches, _StubEngine.lengths, _StubEngine.barrier = [], [], None
    _StubEngine.delay_s, _StubEngine.most_running = 0.3, 0
    try:
        specs = bench.specs(bench.tasks(("fr3",), ("cube",)), 8)
        result = bench.run_gpu(specs, workers=2, device="stub", batch=3, chunk=1, min_batch=1)
    finally:
        _StubEngine.delay_s = 0.0
    executed = [i for i, (_, job) in enumerate(result["planned"]) if job is not None]
    assert len(executed) >= 6 and sorted(result["outcomes"]) == executed
    _, *timed = _StubEngine.batches
    assert sum(timed) == len(executed) and max(timed) <= 3 and result["min_batch"] == 1
    assert _StubEngine.most_running == 1
    # the first batch ran before planning ended: from the one job then waiting
    assert timed[0] < len(executed)
    for lengths in _StubEngine.lengths[1:]:
        assert lengths == sorted(lengths)


@pytest.mark.parametrize("min_batch", [0, 1])
def test_a_warm_start_runs_the_first_batch_before_the_buckets_fill(
    monkeypatch: pytest.MonkeyPatch, min_batch: int
) -> None:
    """bucket 2 with min_batch: the idle device takes the first job planned at once instead of
    waiting for 2 x batch; bucketing alone waits and takes the batch shortest of six."""
    monkeypatch.setattr(mjwarp_engine, "MjwarpEngine", _StubEngine)
    monkeypatch.setenv("BENCH_SLOTS", "2")
    _StubEngine.batches, _StubEngine.lengths, _StubEngine.barrier = [], [], None
    _StubEngine.delay_s = 0.3
    try:
        specs = bench.specs(bench.tasks(("fr3",), ("cube",)), 8)
        result = bench.run_gpu(
            specs, workers=2, device="stub", batch=3, chunk=1, bucket=2, min_batch=min_batch
        )
    finally:
        _StubEngine.delay_s = 0.0
    executed = [i for i, (_, job) in enumerate(result["planned"]) if job is not None]
    assert len(executed) >= 6 and sorted(result["outcomes"]) == executed
    _, *timed = _StubEngine.batches
    assert sum(timed) == len(executed) and max(timed) <= 3
    assert timed[0] == (1 if min_batch else 3)
    for lengths in _StubEngine.lengths[1:]:
        assert lengths == sorted(lengths)


def test_device_time_is_the_union_of_the_batches_spans() -> None:
    from harness.engines.mjwarp.busy_time import union_length

    assert union_length([(0.0, 2.0), (1.0, 3.0), (5.0, 6.0)]) == pytest.approx(4.0)
    assert union_length([(0.0, 4.0), (1.0, 2.0)]) == pytest.approx(4.0)
    assert union_length([]) == 0.0


@pytest.mark.slow
@pytest.mark.gpu
@pytest.mark.skipif(not HAS_WARP, reason="needs the 'gpu' extra (pip install .[gpu])")
def test_lanes_stream_the_planned_jobs_to_the_lockstep_outcomes(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """BENCH_LANES on Warp's CPU device: FR3 episodes of two task models (cube, banana; two
    seeds each) streamed to two lanes per model as they are planned, both streams on the one
    slot, get the outcomes the lockstep batches give them."""
    monkeypatch.setenv("BENCH_SLOTS", "1")
    specs = bench.specs(bench.tasks(("fr3",), ("cube", "banana")), 2)
    streamed = bench.run_gpu(specs, workers=2, device="cpu", chunk=1, lanes=2)
    batched = bench.run_gpu(specs, workers=2, device="cpu", batch=2)
    executed = [i for i, (_, job) in enumerate(batched["planned"]) if job is not None]
    assert executed and sorted(streamed["outcomes"]) == sorted(batched["outcomes"]) == executed
    for i in executed:
        a, b = streamed["outcomes"][i], batched["outcomes"][i]
        assert (a.success, a.failure_reason, a.lift_height_m) == (
            b.success, b.failure_reason, b.lift_height_m,
        )  # fmt: skip
    assert streamed["lanes"] == 2 and streamed["span_steps"] <= streamed["motion_steps"]


@pytest.mark.parametrize(("lanes", "words"), [(0, "2 device batches of <= 8 worlds"),
                                              (8, "1 lane stream(s) of 8 lanes")])  # fmt: skip
def test_the_figures_name_batches_or_lanes(lanes: int, words: str) -> None:
    """The rate's note says how the device was fed; the padding note says idle lanes for lanes,
    and both give the share of the motion's world-steps outside the jobs' spans (here 25%)."""
    gpu = {
        "total_s": 10.0, "plan_s": 8.0, "workers": 3, "batches": 1 if lanes else 2,
        "batch": 8, "lanes": lanes, "device_s": 9.0, "world_steps": 1000, "physics_s": 4.0,
        "tug_s": 1.0, "max_batch": 8, "motion_steps": 800, "span_steps": 600,
        "tug_rungs": 12, "tug_rounds": 2,
    }  # fmt: skip
    result = {"n": 36, "cpu_n": 36, "cpu_s": 36.0, "records": [], "gpu": gpu}
    by_name = {fig.name: fig for fig in bench.figures(result)}
    rate = by_name["episodes per hour, planning on CPU + physics on GPU (mjwarp)"]
    assert rate.median == pytest.approx(3600.0 * 36 / 10.0)
    assert words in (rate.notes or "")
    physics = by_name["physics world-steps per second (mjwarp)"].notes or ""
    assert ("idle lanes 25.0%" if lanes else "padding 25.0%") in physics
