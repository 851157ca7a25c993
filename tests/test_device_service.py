"""The shared devices of a process pool (``harness.engines.mjwarp.service``,
``harness.engines.mjwarp.devices``, ``harness.runs.device_pool``): jobs streamed per task model,
answers as they are judged, errors, the paused episode budget, workers that plan on while their
jobs are on the device, and (slow, Warp's CPU device) a pool sweep whose rows match the
lockstep engine's."""

from __future__ import annotations

import dataclasses
import importlib.util
import threading
import time
from pathlib import Path
from typing import Any

import pytest
from helpers import fr3_device_jobs, same_fields

from harness.config import load_task
from harness.engines.mjwarp import service as service_module
from harness.engines.mjwarp.devices import stream_key
from harness.engines.mjwarp.service import Baton, DeviceReply, DeviceService
from harness.episode import EpisodeSpec
from harness.errors import EpisodeTimeoutError, HarnessError
from harness.objects.assets import repo_root
from harness.pick.outcome import PickOutcome, ValidityMeasure, ValidityResult
from harness.runs import device_pool, thread_budget
from harness.runs.executors import run_process_pool
from harness.sim.budget import budget_paused, check_deadline, episode_budget

HAS_WARP = importlib.util.find_spec("mujoco_warp") is not None


def fr3():
    return load_task(repo_root() / "tasks" / "pick" / "fr3.yaml")


@pytest.fixture(scope="module")
def fr3_jobs() -> list[Any]:
    jobs = fr3_device_jobs(3)
    assert len(jobs) == 3
    return jobs


class _Streams:
    """A stand-in for the lane streams: each stream takes jobs from its source until it ends,
    answering each with a stub outcome naming the stream; ``hold`` jobs are taken before the
    first answer (so a test can require that many jobs in flight at once)."""

    def __init__(self, hold: int = 1, fail: bool = False, patience_s: float = 60.0) -> None:
        self.hold, self.fail, self.patience_s = hold, fail, patience_s
        self.streams: list[list[Any]] = []
        self.lock = threading.Lock()
        self.late = False  # answered jobs after ``patience_s`` without holding ``hold`` of them

    def __call__(self, engine: Any, scene: Any, source: Any, on_outcome: Any, lanes: int) -> None:
        assert scene.model.nbody > 0
        with self.lock:
            self.streams.append([])
            mine = self.streams[-1]
            number = len(self.streams)
        held: list[Any] = []
        deadline = time.monotonic() + self.patience_s
        while True:
            items = source(True)
            if items is None:
                break
            mine.extend(items)
            held.extend(items)
            if self.fail:
                raise RuntimeError("out of device memory")
            if held and len(held) < self.hold and time.monotonic() > deadline:
                self.late = True
            if len(held) >= self.hold or time.monotonic() > deadline:
                for tag, _ in held:
                    on_outcome(
                        tag,
                        PickOutcome(
                            failure_reason="lift_below_threshold",
                            message=f"stream {number}",
                            control_steps=1,
                        ),
                    )
                held = []
                self.hold = 1
        for tag, _ in held:
            on_outcome(tag, PickOutcome(message=f"stream {number}", control_steps=1))


def _service(stub: _Streams, devices: list[str] | None = None) -> DeviceService:
    return DeviceService(devices or ["stub"], make_engine=lambda d: d, run_stream=stub)


def _answers(service: DeviceService, jobs: list[Any]) -> list[DeviceReply]:
    replies: list[DeviceReply | None] = [None] * len(jobs)
    done = threading.Semaphore(0)

    def answer(i: int, reply: DeviceReply) -> None:
        replies[i] = reply
        done.release()

    for i, job in enumerate(jobs):
        service.submit(i, job, lambda reply, i=i: answer(i, reply), track=i)
    for _ in jobs:
        assert done.acquire(timeout=60)
    service.stop()
    assert all(r is not None for r in replies)
    return [r for r in replies if r is not None]


def test_jobs_of_one_task_model_share_a_stream_and_each_gets_its_outcome(fr3_jobs) -> None:
    stub = _Streams(hold=3)
    service = _service(stub)
    replies = _answers(service, fr3_jobs)
    assert [r.track for r in replies] == [0, 1, 2]
    assert all(r.outcome is not None and r.outcome.message == "stream 1" for r in replies)
    assert len(stub.streams) == 1 and len(stub.streams[0]) == 3
    assert (service.stats.jobs, service.stats.streams) == (3, 1)


def test_approach_cones_share_a_stream_key(fr3_jobs) -> None:
    """The stream key is the device model and timing: a job whose task differs only in its
    grasp filter (a sweep's approach cone) goes to the same stream."""
    job = fr3_jobs[0]
    pick = job.task.pick.model_copy(update={"pre_grasp_offset": 0.2})
    other = dataclasses.replace(job, task=job.task.model_copy(update={"pick": pick}))
    assert stream_key(other) == stream_key(job)
    hold = job.task.pick.model_copy(update={"hold_time": 2 * job.task.pick.hold_time})
    longer = dataclasses.replace(job, task=job.task.model_copy(update={"pick": hold}))
    assert stream_key(longer) != stream_key(job)


def test_a_failed_stream_answers_every_job_it_took_with_the_error(fr3_jobs) -> None:
    service = _service(_Streams(fail=True))
    replies = _answers(service, fr3_jobs)
    assert all(r.outcome is None for r in replies)
    assert all("RuntimeError: out of device memory" in (r.error or "") for r in replies)
    assert service.stats.errors


def test_two_devices_each_run_a_stream_of_the_same_key(fr3_jobs) -> None:
    """Two devices: while the first device's stream holds its jobs (it answers once it has
    two), the second takes the rest of the queue: both streams run at once."""
    entered = threading.Barrier(2)

    class Two(_Streams):
        def __call__(self, engine: Any, scene: Any, *args: Any) -> None:
            entered.wait(timeout=60)  # fewer than two streams at once would time out here
            super().__call__(engine, scene, *args)

    stub = Two(hold=1)
    service = DeviceService(["cuda:0", "cuda:1"], make_engine=lambda d: d, run_stream=stub)
    replies: list[DeviceReply] = []
    done = threading.Semaphore(0)

    def answer(reply: DeviceReply) -> None:
        replies.append(reply)
        done.release()

    for i, job in enumerate(fr3_jobs * 2):
        service.submit(i, job, answer)
        time.sleep(0.05)
    for _ in range(6):
        assert done.acquire(timeout=60)
    service.stop()
    assert all(r.outcome is not None for r in replies), [r.error for r in replies]
    assert sorted(service.stats.by_device) == ["cuda:0", "cuda:1"]


def _keyed(job: Any, k: int) -> Any:
    """``job`` as a job of another stream key (its hold time differs)."""
    pick = job.task.pick.model_copy(update={"hold_time": job.task.pick.hold_time + 0.25 * k})
    return dataclasses.replace(job, task=job.task.model_copy(update={"pick": pick}))


class _Concurrent(_Streams):
    """Stub streams that count how many run at once (and with how many lanes)."""

    def __init__(self, barrier: threading.Barrier | None = None, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.barrier = barrier
        self.running = 0
        self.most = 0
        self.lanes: list[int] = []

    def __call__(self, engine: Any, scene: Any, source: Any, on_outcome: Any, lanes: int) -> None:
        with self.lock:
            self.running += 1
            self.most = max(self.most, self.running)
            self.lanes.append(lanes)
        try:
            if self.barrier is not None:
                self.barrier.wait(timeout=60)  # fewer streams at once would time out here
            time.sleep(0.1)
            super().__call__(engine, scene, source, on_outcome, lanes)
        finally:
            with self.lock:
                self.running -= 1


def test_the_task_models_of_a_run_stream_side_by_side_on_one_device(fr3_jobs) -> None:
    """Three stream keys, three streams per device: all three streams run at once (each holds
    its first job until the other two have started), each answers its own key's jobs."""
    jobs = [_keyed(fr3_jobs[0], k) for k in range(3)]
    assert len({stream_key(j) for j in jobs}) == 3
    stub = _Concurrent(threading.Barrier(3))
    service = DeviceService(["stub"], make_engine=lambda d: d, run_stream=stub, per_device=3)
    replies = _answers(service, jobs * 2)
    assert all(r.outcome is not None for r in replies), [r.error for r in replies]
    assert stub.most == 3 and service.stats.concurrent == 3
    assert service.stats.jobs == 6
    for stream in stub.streams:  # one key per stream
        assert len({stream_key(job) for _, job in stream}) == 1


def test_more_task_models_than_streams_wait_their_turn(fr3_jobs) -> None:
    """Five keys, two streams per device: never more than two at once, every job answered
    exactly once; an idle stream makes way for a waiting key (it does not wait for close)."""
    jobs = [_keyed(fr3_jobs[0], k) for k in range(5)]
    stub = _Concurrent()
    service = DeviceService(["stub"], make_engine=lambda d: d, run_stream=stub, per_device=2)
    replies = _answers(service, jobs * 3)
    assert all(r.outcome is not None for r in replies), [r.error for r in replies]
    assert sorted(r.track for r in replies) == list(range(15))
    assert stub.most == 2 and service.stats.concurrent == 2
    assert sum(len(s) for s in stub.streams) == 15 == service.stats.jobs
    assert service.stats.streams >= 5


def test_a_streams_lanes_follow_its_task_models_jobs(
    fr3_jobs, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Lanes per key from the jobs the run expects of it (``expect``): 3,000 FR3 jobs get
    1,024 lanes (the measured best for one stream), 100 get 128 (a lane each: one span);
    within the device's budget."""
    from harness.engines.mjwarp.devices import DeviceStreams

    monkeypatch.delenv("HARNESS_LANES", raising=False)
    monkeypatch.delenv("HARNESS_DEVICE_LANES", raising=False)
    big, small = fr3_jobs[0], _keyed(fr3_jobs[0], 1)
    stub = _Concurrent(threading.Barrier(2))
    streams = DeviceStreams(["cuda:0"], make_engine=lambda d: d, run_stream=stub, per_device=2)
    streams.expect([big.task] * 3000 + [small.task] * 100)
    assert streams.planned_lanes() == 1024 + 128
    done = threading.Semaphore(0)
    for tag, job in enumerate([big, small]):
        streams.submit(tag, job, lambda outcome, error: done.release())
    for _ in range(2):
        assert done.acquire(timeout=60)
    streams.close()
    assert sorted(stub.lanes) == [128, 1024]
    monkeypatch.setenv("HARNESS_DEVICE_LANES", "512")  # the budget caps the sum
    assert streams.planned_lanes() == 512


def test_ten_task_models_stream_at_once_within_the_devices_budget(
    fr3_jobs, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A tune's refinement on one GPU: ten task models of 4,000 jobs each. Each wants 2,048
    lanes (a third of its jobs), but eight of those fill the device's 16,384 and two would wait
    a whole stream; with the budget split evenly, all ten run at once with 1,600 lanes."""
    from harness.engines.mjwarp.devices import DeviceStreams
    from harness.engines.mjwarp.lane_sizes import CUDA_DEVICE_LANES, CUDA_STREAMS, even_share

    monkeypatch.delenv("HARNESS_LANES", raising=False)
    monkeypatch.delenv("HARNESS_DEVICE_LANES", raising=False)
    monkeypatch.delenv("HARNESS_STREAMS_PER_DEVICE", raising=False)
    assert CUDA_STREAMS >= 10 and CUDA_DEVICE_LANES == 16384
    assert even_share(16384, [2048] * 10, 64) == 1600  # 1,638 in multiples of the floor
    assert even_share(16384, [2048] * 8, 64) == 16384  # all fit: no cap
    assert even_share(16384, [128, 8192, 8192], 64) == 8128  # the small one's rest shared
    assert even_share(512, [1024, 128], 64) == 384 and even_share(100, [512] * 10, 64) == 64
    jobs = [_keyed(fr3_jobs[0], k) for k in range(10)]
    stub = _Concurrent(threading.Barrier(10))
    streams = DeviceStreams(["cuda:0"], make_engine=lambda d: d, run_stream=stub)
    streams.expect([job.task for job in jobs for _ in range(4000)])
    assert streams.planned_lanes() == 10 * 1600
    done = threading.Semaphore(0)
    for tag, job in enumerate(jobs):
        streams.submit(tag, job, lambda outcome, error: done.release())
    for _ in jobs:
        assert done.acquire(timeout=60)  # the barrier needs all ten streams at once
    streams.close()
    assert stub.most == 10 and stub.lanes == [1600] * 10


def test_the_wait_for_the_device_is_not_the_episodes_time() -> None:
    with episode_budget(0.2, 10):
        with budget_paused():
            time.sleep(0.3)
        check_deadline()  # the 0.3 s paused does not count
        with pytest.raises(EpisodeTimeoutError):  # the alarm is armed again after the pause
            time.sleep(0.25)
            check_deadline()


def test_each_thread_has_its_own_episode_budget() -> None:
    """A worker's episode threads: one past its limit does not end another's."""
    errors: list[str] = []
    inside = threading.Barrier(2)

    def episode(limit: float, sleep: float) -> None:
        with episode_budget(limit, 10):
            inside.wait(timeout=10)
            time.sleep(sleep)
            try:
                check_deadline()
            except EpisodeTimeoutError:
                errors.append(f"{limit}")

    threads = [threading.Thread(target=episode, args=a) for a in ((0.05, 0.2), (30.0, 0.2))]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert errors == ["0.05"]


def test_the_baton_lets_one_thread_plan_while_another_waits_for_its_reply() -> None:
    holders: list[int | None] = []
    baton = Baton(holders.append)
    log: list[str] = []

    def first() -> None:
        baton.hold(0)
        baton.expect(0)
        log.append("0 sent")
        reply = baton.wait_for(0, 10)
        log.append(f"0 got {reply.outcome.message if reply and reply.outcome else None}")
        baton.release()

    thread = threading.Thread(target=first)
    thread.start()
    while "0 sent" not in log:
        time.sleep(0.01)
    baton.hold(1)  # the first thread waits for its reply: the baton is free
    log.append("1 planned")
    baton.deliver(DeviceReply(0, PickOutcome(message="ok")))
    time.sleep(0.1)
    assert "0 got ok" not in log  # it needs the baton back first
    baton.release()
    thread.join(timeout=10)
    assert log == ["0 sent", "1 planned", "0 got ok"]
    assert holders == [0, 1, 0]


def test_depth_keeps_two_episodes_per_lane_in_flight(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("HARNESS_IN_FLIGHT_PER_LANE", raising=False)
    assert thread_budget.IN_FLIGHT_PER_LANE == 2
    box = 16384  # half of Linux's default pid_max (harness.runs.thread_budget)
    assert device_pool.depth_for(2048, 1, 31, box) == 133  # ceil(2 * 2048 / 31)
    assert device_pool.depth_for(8192, 1, 31, threads=8192) == 264  # 8,192 threads over 31
    assert device_pool.depth_for(8192, 1, 15, threads=box // 2) == 546  # a GPU's share of two
    assert device_pool.depth_for(4, 1, 2, box) == 4
    assert device_pool.depth_for(1, 1, 32, box) == 2  # at least one planning and one waiting
    assert device_pool.depth_for(10**6, 1, 1, box) == thread_budget.MAX_DEPTH
    assert device_pool.depth_for(10**6, 1, 10**5, box) == 2  # a planning and a waiting one
    # share groups of three cones: a thread per episode, so a third of the groups; two GPUs
    # of 15 workers each under the default pid_max held 8,192 threads a GPU, not 16,000
    assert device_pool.depth_for(8192, 1, 15, threads=box // 2, group=3) == 182
    assert device_pool.depth_for(1024, 1, 15, threads=10**6, group=3) == 46  # 2 a lane
    monkeypatch.setenv("HARNESS_IN_FLIGHT_PER_LANE", "4")  # measured slower, 2026-11-28
    assert device_pool.depth_for(1024, 1, 15, threads=10**6, group=3) == 92
    monkeypatch.setenv("HARNESS_IN_FLIGHT_PER_LANE", "four")  # one line naming the variable
    with pytest.raises(HarnessError, match="HARNESS_IN_FLIGHT_PER_LANE='four': not an integer"):
        device_pool.depth_for(1024, 1, 15, threads=10**6, group=3)


def test_a_cuda_stream_has_lanes_for_the_runs_size(monkeypatch: pytest.MonkeyPatch) -> None:
    from harness.engines.mjwarp.lane_sizes import default_lanes

    monkeypatch.delenv("HARNESS_LANES", raising=False)
    assert default_lanes("cuda:0", 3000) == 1024  # the best of 1,024 / 2,048 / 8,192 measured
    assert default_lanes("cuda:0", 10) == 64  # the floor: a stream's lanes add to the others'
    assert default_lanes("cuda:0", 112) == 128  # a tune round's look: one span, not two
    assert default_lanes("cuda:0", 300) == default_lanes("cuda:0", 512) == 512  # one span
    assert default_lanes("cuda:0", 600) == 512  # past one span's lanes: the floor of the rule
    assert default_lanes("cuda:0", 65536) == default_lanes("cuda:0") == 8192
    assert default_lanes("cpu", 3000) == 4
    monkeypatch.setenv("HARNESS_LANES", "64")
    assert default_lanes("cuda:1", 3000) == 64


def _stub_service(monkeypatch: pytest.MonkeyPatch, stub: _Streams) -> None:
    original = DeviceService.__init__

    def with_stub(self: DeviceService, devices: Any = None, **streams: Any) -> None:
        original(self, ["stub"], lanes=4, make_engine=lambda d: d, run_stream=stub)

    monkeypatch.setattr(service_module.DeviceService, "__init__", with_stub)


def test_a_pool_plans_on_while_its_jobs_wait_for_the_device(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Two workers, six episodes: the stub device answers nothing until it holds four jobs, so
    a worker blocked on its first job (at most two in flight) would never finish. Every row
    carries the device's outcome and the engine's name; the job count is the rows executed."""
    stub = _Streams(hold=4)
    _stub_service(monkeypatch, stub)
    monkeypatch.setattr(
        device_pool, "depth_for", lambda lanes, devices, workers, threads=0, group=1: 3
    )
    episodes = _fr3_device_episodes(6)
    rows: list[dict[str, Any]] = []
    stats = run_process_pool(episodes, tmp_path, "none", rows.append, workers=2)
    assert stats.finished == 6 and not stats.crashed
    assert sorted(r["seed"] for r in rows) == list(range(6))
    # every row's life counted, at most the run's wall each (Little's law line of the sweep)
    assert stats.lives == 6 and 0 < stats.lives_s <= 6 * stats.wall_time_s
    executed = [r for r in rows if r["error_message"].startswith("stream ")]
    assert len(executed) == stats.device.jobs >= 4
    assert sum(len(s) for s in stub.streams) == stats.device.jobs
    assert all(r["engine"] == "mjwarp" for r in rows)


def test_a_share_groups_next_episode_plans_while_the_one_before_is_on_the_device(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """FR3 seed 0 at approach cones 100, 140 and 160 degrees (chosen candidates 20, 20 and 34 on
    the CPU engine), one worker of one track: the stub device answers nothing until it holds two
    jobs. The 140 episode chooses the candidate whose job (the 100 episode's) is on the device
    and waits for that outcome instead of sending it again, and the 160 episode plans and sends
    its own job meanwhile; a track that started its next episode only after the one before had
    its row would hold one job and wait out the stub's patience."""
    stub = _Streams(hold=2, patience_s=20.0)
    _stub_service(monkeypatch, stub)
    monkeypatch.setattr(
        device_pool, "depth_for", lambda lanes, devices, workers, threads=0, group=1: 1
    )
    episodes = _cone_episodes((100, 140, 160))
    rows: list[dict[str, Any]] = []
    stats = run_process_pool(episodes, tmp_path, "none", rows.append, workers=1)
    assert stats.finished == 3 and not stats.crashed and not stats.device.errors
    assert not stub.late
    assert stats.device.jobs == 2 == sum(len(s) for s in stub.streams)
    by_cone = {r["approach_filter"]: r for r in rows}
    cones = [f'["downward", {deg:.1f}]' for deg in (100, 140, 160)]
    assert [by_cone[cone]["chosen_index"] for cone in cones] == [20, 20, 34]
    messages = [by_cone[cone]["error_message"] for cone in cones]
    assert messages[0] == messages[1] == "stream 1"  # one outcome, the 140 row reused it


def _cone_episodes(degrees: tuple[int, ...], seed: int = 0) -> list[EpisodeSpec]:
    """FR3 cube episodes of one seed at these approach cones (one share group), on ``mjwarp``."""
    from harness.config import apply_overrides
    from harness.runs.expansion import point_overrides

    base = fr3()
    return [
        dataclasses.replace(
            EpisodeSpec(
                task=apply_overrides(
                    base, point_overrides(base, {"pick.approach_filter": ["downward", deg]})
                ),
                seed=seed,
                episode_index=seed,
            ),
            engine="mjwarp",
        )
        for deg in degrees
    ]


@pytest.mark.slow
def test_a_worker_that_dies_inside_a_pipelined_group_loses_no_episode(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """One share group (FR3 seed 0 at three cones), one worker: the worker segfaults (once) as
    the group's second episode starts, while the first one's job is out. The second episode is
    retried, the first and the third run again on a new worker: three rows, none an error."""
    from harness.runs.worker import FAULT_ENV, FAULT_ONCE_ENV

    _stub_service(monkeypatch, _Streams())
    monkeypatch.setattr(
        device_pool, "depth_for", lambda lanes, devices, workers, threads=0, group=1: 1
    )
    episodes = _cone_episodes((100, 140, 160))
    monkeypatch.setenv(FAULT_ENV, episodes[1].resolved_id)
    monkeypatch.setenv(FAULT_ONCE_ENV, str(tmp_path))
    rows: list[dict[str, Any]] = []
    stats = run_process_pool(episodes, tmp_path / "run", "none", rows.append, workers=1)
    assert stats.finished == 3 and stats.retried == 1 and not stats.crashed
    assert sorted(r["approach_filter"] for r in rows) == sorted(
        f'["downward", {deg:.1f}]' for deg in (100, 140, 160)
    )
    assert all(r["failure_reason"] != "error" for r in rows)
    assert all(r["error_message"].startswith("stream ") for r in rows if r["sim_steps"])


def _fr3_device_episodes(count: int) -> list[EpisodeSpec]:
    """FR3 episodes 0..count-1 (seed = index) for the ``mjwarp`` engine."""
    return [
        dataclasses.replace(EpisodeSpec(task=fr3(), seed=s, episode_index=s), engine="mjwarp")
        for s in range(count)
    ]


def _held_measure(depth: float) -> ValidityMeasure:
    """A grasp that passes every validity term but the table's (at ``depth`` > 2 mm)."""
    return ValidityMeasure(
        ran=True, table_penetration_m=depth, lift_height_m=0.1, closing_forces=(5.0, 5.0),
        finger_forces=(5.0, 5.0), hold_slip_m=0.001, hold_rotation_rad=0.01, robustness_g=4.0,
        object_speed=0.0, joint_speed=0.0,
    )  # fmt: skip


class _TableStreams:
    """A stand-in device for the table verdict: it holds the task's three jobs, then answers
    each with a reference success whose row identifies it (``lift_height_m`` 0.10, 0.11, 0.12
    by the object's start x); the first two went 3 mm into the (non-physical) table, the third
    did not touch it. A job of any other contact bits fails the test (replays run on the CPU
    engine)."""

    def __init__(self, base_key: str) -> None:
        self.base_key = base_key
        self.streams: list[list[Any]] = []

    def __call__(self, engine: Any, scene: Any, source: Any, on_outcome: Any, lanes: int) -> None:
        mine: list[Any] = []
        self.streams.append(mine)
        held: list[tuple[Any, Any]] = []
        while (items := source(True)) is not None:
            assert all(job.contact_key == self.base_key for _, job in items)
            mine.extend(job for _, job in items)
            held.extend(items)
            if len(held) == 3:
                held.sort(key=lambda item: float(item[1].object_init_position[0]))
                for rank, (tag, _) in enumerate(held):
                    depth = 0.003 if rank < 2 else 0.0
                    measure = _held_measure(depth)
                    validity = ValidityResult(
                        depth == 0.0, "" if depth == 0.0 else "table_penetration", "", measure
                    )
                    on_outcome(
                        tag,
                        PickOutcome(
                            success=True, control_steps=1, lift_height_m=0.10 + 0.01 * rank,
                            table_penetration_m=depth, validity=validity,
                        ),
                    )  # fmt: skip
                held = []


def test_a_pool_replays_a_pick_through_the_table_on_the_cpu_engine(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """FR3 (robot-table contact non-physical), three episodes on a stub device: the device gets
    each episode's one job, with the task's contact bits; the two whose fingers went into the
    table are replayed on the physical table by the CPU engine in the worker
    (``table_verdict.REPLAY_ENGINE``), and their rows' ``valid`` and ``invalid_reason`` follow
    that replay's ``table_replay`` (``physical_verdict``); the third has no replay."""
    from harness.engines.mjwarp.contact import contact_key
    from harness.episode.scene_cache import get_scene
    from harness.sim.masks import contact_bits

    scene = get_scene(fr3(), {}).scene
    stub = _TableStreams(contact_key(contact_bits(scene.model)))
    _stub_service(monkeypatch, stub)  # type: ignore[arg-type]
    monkeypatch.setattr(
        device_pool, "depth_for", lambda lanes, devices, workers, threads=0, group=1: 3
    )
    episodes = _fr3_device_episodes(3)
    rows: list[dict[str, Any]] = []
    stats = run_process_pool(episodes, tmp_path, "none", rows.append, workers=1)
    assert stats.finished == 3 and not stats.crashed and not stats.device.errors
    assert stats.device.jobs == 3 and sum(len(stream) for stream in stub.streams) == 3
    by_rank = {round((r["lift_height_m"] - 0.10) / 0.01): r for r in rows}
    for deep in (by_rank[0], by_rank[1]):
        assert deep["table_penetration_m"] == 0.003 and deep["table_replay"] != ""
        held = deep["table_replay"] == "held"
        assert (deep["valid"], deep["invalid_reason"]) == (
            (True, "") if held else (False, "table_penetration")
        )
    clean = by_rank[2]
    assert (clean["table_replay"], clean["valid"], clean["table_penetration_m"]) == ("", True, 0.0)
    assert all(r["success"] and r["engine"] == "mjwarp" for r in rows)


@pytest.mark.slow
def test_a_pool_shares_candidates_as_on_the_cpu(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Points that differ only in a selection key (two approach cones) share each seed's
    evaluation: the rows are those without sharing, and the device executes no more jobs."""
    from harness.config import apply_overrides
    from harness.runs.expansion import point_overrides

    _stub_service(monkeypatch, _Streams())
    base = fr3()
    cones = [
        apply_overrides(base, point_overrides(base, {"pick.approach_filter": ["downward", deg]}))
        for deg in (140, 160)
    ]
    episodes = [
        dataclasses.replace(EpisodeSpec(task=t, seed=s, episode_index=s), engine="mjwarp")
        for s in range(2)
        for t in cones
    ]
    shared: list[dict[str, Any]] = []
    with_sharing = run_process_pool(episodes, tmp_path / "a", "none", shared.append, workers=2)
    alone: list[dict[str, Any]] = []
    without = run_process_pool(
        episodes, tmp_path / "b", "none", alone.append, workers=2, share=False
    )
    assert with_sharing.finished == without.finished == 4
    assert with_sharing.device.jobs <= without.device.jobs
    by_id = {(r["episode_id"], r["approach_filter"]): r for r in alone}
    for row in shared:
        twin = by_id[row["episode_id"], row["approach_filter"]]
        for column in ("success", "failure_reason", "traj_duration_s", "tcp_grasp_error_m"):
            assert row[column] == twin[column] or (row[column] != row[column]), column


@pytest.mark.slow
@pytest.mark.gpu
@pytest.mark.skipif(not HAS_WARP, reason="needs the 'gpu' extra (pip install .[gpu])")
def test_a_pool_sweep_on_warps_cpu_device_gives_the_lockstep_rows(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Three FR3 cube episodes planned by two workers and streamed through two lanes on Warp's
    CPU device: the same verdicts and measures as the same jobs run as one lockstep batch
    (``MjwarpEngine.execute_many``), and the CPU engine's row columns."""
    from harness.engines.mjwarp.engine import MjwarpEngine
    from harness.episode.scene_cache import get_scene

    monkeypatch.setenv("HARNESS_WARP_DEVICE", "cpu")
    monkeypatch.setenv("HARNESS_LANES", "2")
    task = fr3().model_copy(update={"limits": fr3().limits.model_copy(update={"wall_time_s": 60})})
    episodes = [EpisodeSpec(task=task, seed=s, episode_index=s) for s in range(3)]
    on_gpu = [dataclasses.replace(e, engine="mjwarp") for e in episodes]
    rows: list[dict[str, Any]] = []
    stats = run_process_pool(on_gpu, tmp_path / "gpu", "none", rows.append, workers=2)
    assert stats.finished == 3 and not stats.device.errors
    jobs = fr3_device_jobs(3)
    reference, _ = MjwarpEngine("cpu").execute_many(get_scene(task, {}).scene, jobs)
    by_seed = {r["seed"]: r for r in rows}
    assert stats.device.jobs == len(jobs) == 3
    for seed, outcome in enumerate(reference):
        row = by_seed[seed]
        assert row["failure_reason"] != "timeout"
        assert row["success"] == outcome.success
        assert (row["failure_reason"] or "") == (outcome.failure_reason or "")
        assert row["lift_height_m"] == pytest.approx(outcome.lift_height_m, abs=1e-9)
        assert outcome.validity is not None
        assert row["valid"] == outcome.validity.valid
    cpu: list[dict[str, Any]] = []
    run_process_pool(episodes, tmp_path / "cpu", "none", cpu.append, workers=2)
    assert list(rows[0]) == list(cpu[0])


@pytest.mark.slow
@pytest.mark.gpu
@pytest.mark.ray
@pytest.mark.skipif(not HAS_WARP, reason="needs the 'gpu' extra (pip install .[gpu])")
def test_a_ray_sweep_on_loopback_streams_to_the_device_actor(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``--backend ray --engine mjwarp`` on a local Ray (loopback) with Warp's CPU device: two
    planning actors feed the node's device actor; two FR3 cube episodes get the lockstep
    batch's verdicts."""
    pytest.importorskip("ray")
    from harness.engines.mjwarp.engine import MjwarpEngine
    from harness.episode.scene_cache import get_scene
    from harness.runs.executors import run_ray

    monkeypatch.setenv("HARNESS_WARP_DEVICE", "cpu")
    monkeypatch.setenv("HARNESS_LANES", "2")
    task = fr3().model_copy(update={"limits": fr3().limits.model_copy(update={"wall_time_s": 60})})
    episodes = [
        dataclasses.replace(EpisodeSpec(task=task, seed=s, episode_index=s), engine="mjwarp")
        for s in range(2)
    ]
    rows: list[dict[str, Any]] = []
    stats = run_ray(episodes, tmp_path, "none", rows.append, workers=2)
    assert stats.finished == 2 and not stats.crashed
    assert stats.lives == 2 and 0 < stats.lives_s <= 2 * stats.wall_time_s  # flight_line's
    assert stats.device is not None and stats.device.jobs == 2 and not stats.device.errors
    jobs = fr3_device_jobs(2)
    reference, _ = MjwarpEngine("cpu").execute_many(get_scene(task, {}).scene, jobs)
    by_seed = {r["seed"]: r for r in rows}
    for seed, outcome in enumerate(reference):
        row = by_seed[seed]
        assert row["engine"] == "mjwarp" and row["failure_reason"] != "timeout"
        assert (row["success"], row["failure_reason"] or "") == (
            outcome.success, outcome.failure_reason or "",
        )  # fmt: skip
        assert row["lift_height_m"] == pytest.approx(outcome.lift_height_m, abs=1e-9)


@pytest.mark.slow
@pytest.mark.gpu
@pytest.mark.skipif(not HAS_WARP, reason="needs the 'gpu' extra (pip install .[gpu])")
def test_two_task_models_streamed_side_by_side_give_the_verdicts_of_one_at_a_time(
    fr3_jobs, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Warp's CPU device, real lane streams: an FR3 cube job and its twin of another stream key
    (a longer hold: another validity window) run as two streams at once on one device (each
    its own slot, the host lock passed between them) and give, field by field, the outcomes
    the same jobs get one stream at a time."""

    from harness.engines.mjwarp.devices import DeviceStreams

    monkeypatch.setenv("HARNESS_WARP_DEVICE", "cpu")
    monkeypatch.delenv("HARNESS_LANES", raising=False)
    jobs = [fr3_jobs[0], _keyed(fr3_jobs[0], 1)]

    def run(per_device: int) -> tuple[list[PickOutcome | None], Any]:
        streams = DeviceStreams(["cpu"], lanes=1, per_device=per_device)
        outcomes: list[PickOutcome | None] = [None, None]
        errors: list[str] = []

        def answer(k: int, outcome: PickOutcome | None, error: str | None) -> None:
            outcomes[k] = outcome
            if error:
                errors.append(error)

        for k, job in enumerate(jobs):
            streams.submit(k, job, lambda o, e, k=k: answer(k, o, e))
        streams.close()
        assert not errors and not streams.stats.errors, errors
        return outcomes, streams.stats

    alone, alone_stats = run(1)
    together, together_stats = run(2)
    assert alone_stats.concurrent == 1 and together_stats.concurrent == 2
    assert together_stats.streams == 2 and together_stats.jobs == 2
    assert all(o is not None for o in alone + together)
    for one, both in zip(alone, together, strict=True):
        assert same_fields(one, both)


@pytest.mark.gpu
@pytest.mark.skipif(not HAS_WARP, reason="needs the 'gpu' extra (pip install .[gpu])")
def test_a_runs_device_models_load_before_its_first_job(monkeypatch: pytest.MonkeyPatch) -> None:
    """``prepare`` makes each expected task model's device model in the background (on Warp's
    CPU device here); the stream of the first job then uses that model instead of making one."""
    from harness.engines.mjwarp import devices

    monkeypatch.setattr(devices, "_ENGINES", {})
    streams = devices.DeviceStreams(["cpu"])
    task = fr3()
    streams.expect([task, task])
    streams.prepare()
    assert streams._prewarm is not None
    streams._prewarm.join(timeout=600)
    engine = streams._engine("cpu")
    assert len(engine._models) == 1
    (model,) = engine._models.values()
    scene = devices.scene_for(task, streams._scenes, streams._scene_lock)
    assert engine.batch(scene, task).dm is model
    streams.close()


def test_the_switch_interval_is_set_while_the_streams_run(
    fr3_jobs, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``HARNESS_SWITCH_INTERVAL_MS``: the interpreter switches threads at that interval while
    the device streams serve (seen from inside a stream), and at its own again after ``close``;
    a value that is not a positive number is one line naming the variable."""
    import sys

    from harness.engines.mjwarp.devices import DeviceStreams
    from harness.errors import HarnessError

    before = sys.getswitchinterval()
    seen: list[float] = []

    def stream(engine: object, scene: object, source, on_outcome, lanes: int) -> None:  # type: ignore[no-untyped-def]
        seen.append(sys.getswitchinterval())
        while (jobs := source(True)) is not None:
            for tag, _ in jobs:
                on_outcome(tag, None)

    monkeypatch.setenv("HARNESS_SWITCH_INTERVAL_MS", "0.5")
    streams = DeviceStreams(["stub"], make_engine=lambda d: d, run_stream=stream, per_device=1)
    done = threading.Semaphore(0)
    streams.submit(0, fr3_jobs[0], lambda outcome, error: done.release())
    assert done.acquire(timeout=60)
    streams.close()
    assert seen == [0.0005] and sys.getswitchinterval() == before
    monkeypatch.setenv("HARNESS_SWITCH_INTERVAL_MS", "fast")
    with pytest.raises(HarnessError, match="HARNESS_SWITCH_INTERVAL_MS='fast'"):
        DeviceStreams(["stub"], make_engine=lambda d: d, run_stream=stream, per_device=1)


def test_two_devices_share_one_keys_jobs_a_streams_room_at_a_time(fr3_jobs) -> None:
    """A stream takes at most the jobs it has room for (``want``: its free lanes and a
    reserve); the rest stay queued, where the other device's stream of the same key takes
    them: twelve jobs of one key, streams taking two at a time, both devices answer some."""
    from harness.engines.mjwarp.devices import DeviceStreams

    taken: dict[str, int] = {}
    lock = threading.Lock()

    def stream(engine: Any, scene: Any, source: Any, on_outcome: Any, lanes: int) -> None:
        while (jobs := source(True, 2)) is not None:
            assert len(jobs) <= 2
            time.sleep(0.2)  # the device steps them
            with lock:
                taken[engine] = taken.get(engine, 0) + len(jobs)
            for tag, _ in jobs:
                on_outcome(tag, None)

    streams = DeviceStreams(
        ["cuda:0", "cuda:1"], make_engine=lambda d: d, run_stream=stream, per_device=1
    )
    done = threading.Semaphore(0)
    for tag in range(12):
        streams.submit(tag, fr3_jobs[0], lambda outcome, error: done.release())
    for _ in range(12):
        assert done.acquire(timeout=60)
    streams.close()
    assert sum(taken.values()) == 12
    assert sorted(taken) == ["cuda:0", "cuda:1"] and min(taken.values()) >= 2, taken


def test_two_devices_serving_one_key_take_even_shares_of_what_waits(fr3_jobs) -> None:
    """Both devices' streams of one key have room for every job and lanes at work; 42 jobs
    wait: each takes half (before, the first to ask took them all and the other device idled;
    a stream whose lanes are idle still takes what it has room for)."""
    from harness.engines.mjwarp.devices import DeviceStreams

    both = threading.Barrier(2)
    queued = threading.Event()
    taken: dict[str, int] = {}
    lock = threading.Lock()

    def stream(engine: Any, scene: Any, source: Any, on_outcome: Any, lanes: int) -> None:
        both.wait(timeout=60)  # both streams serve the key before the jobs are queued
        assert queued.wait(timeout=60)
        block = False  # a stream with work in its lanes: it takes its share, not its room
        while (jobs := source(block, 100)) is not None:
            block = not jobs
            with lock:
                taken[engine] = taken.get(engine, 0) + len(jobs)
            time.sleep(0.2)  # the device steps them
            for tag, _ in jobs:
                on_outcome(tag, None)

    streams = DeviceStreams(
        ["cuda:0", "cuda:1"], make_engine=lambda d: d, run_stream=stream, per_device=1
    )
    done = threading.Semaphore(0)
    for tag in range(2):  # one job each starts a stream on each device
        streams.submit(tag, fr3_jobs[0], lambda outcome, error: done.release())
    deadline = time.monotonic() + 60
    while streams._serving(stream_key(fr3_jobs[0])) < 2 and time.monotonic() < deadline:
        time.sleep(0.01)
    for tag in range(2, 42):
        streams.submit(tag, fr3_jobs[0], lambda outcome, error: done.release())
    queued.set()
    for _ in range(42):
        assert done.acquire(timeout=60)
    streams.close()
    assert sum(taken.values()) == 42
    assert sorted(taken) == ["cuda:0", "cuda:1"] and min(taken.values()) >= 20, taken
    assert streams.stats.jobs_by_device == taken  # what the sweep's device line shows


def test_stream_timings_add_up_and_keep_the_larger_peaks() -> None:
    """``add_timings`` sums every field of two streams' timings except the peaks, which keep
    the larger (a field added to the timings is summed without being listed anywhere)."""
    from dataclasses import dataclass

    from harness.engines.mjwarp.stream_stats import add_timings

    @dataclass
    class Timings:
        physics_s: float = 0.0
        visits: int = 0
        peak_rows: int = 0
        peak_contacts: float = 0.0

    total, more = Timings(1.5, 3, 100, 2.0), Timings(0.5, 4, 80, 3.5)
    add_timings(total, more)
    assert total == Timings(2.0, 7, 100, 3.5)
