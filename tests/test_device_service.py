"""The shared device of a process pool (``harness.engines.mjwarp.service``): batching, answers,
errors, the paused episode budget, and a pool run whose mjwarp jobs go to the parent."""

from __future__ import annotations

import dataclasses
import importlib.util
import threading
import time
from pathlib import Path
from typing import Any

import pytest
from helpers import fr3_device_jobs

from harness.config import load_task
from harness.engines.mjwarp import service as service_module
from harness.engines.mjwarp.service import DeviceReply, DeviceService
from harness.episode import EpisodeSpec
from harness.errors import EpisodeTimeoutError
from harness.objects.assets import repo_root
from harness.pick.outcome import PickOutcome
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


def _answers(service: DeviceService, jobs: list[Any]) -> list[DeviceReply]:
    replies: list[DeviceReply | None] = [None] * len(jobs)
    done = threading.Semaphore(0)

    def answer(i: int, reply: DeviceReply) -> None:
        replies[i] = reply
        done.release()

    for i, job in enumerate(jobs):
        service.submit(job, lambda reply, i=i: answer(i, reply))
    for _ in jobs:
        assert done.acquire(timeout=60)
    service.stop()
    assert all(r is not None for r in replies)
    return [r for r in replies if r is not None]


def test_waiting_jobs_run_as_one_batch_and_each_gets_its_own_outcome(fr3_jobs) -> None:
    batches: list[int] = []

    def execute(scene: Any, jobs: list[Any]) -> list[PickOutcome]:
        assert scene.model.nbody > 0
        batches.append(len(jobs))
        return [PickOutcome(message=f"job {id(job)}") for job in jobs]

    service = DeviceService(lambda: len(fr3_jobs), execute=execute)
    replies = _answers(service, fr3_jobs)
    assert batches == [3]
    assert [r.outcome.message for r in replies if r.outcome] == [
        f"job {id(job)}" for job in fr3_jobs
    ]
    assert (service.stats.batches, service.stats.jobs, service.stats.largest) == (1, 3, 3)


def test_a_failed_batch_answers_every_job_with_the_error(fr3_jobs) -> None:
    def execute(scene: Any, jobs: list[Any]) -> list[PickOutcome]:
        raise RuntimeError("out of device memory")

    service = DeviceService(lambda: len(fr3_jobs), execute=execute)
    replies = _answers(service, fr3_jobs)
    assert all(r.outcome is None for r in replies)
    assert all("RuntimeError: out of device memory" in (r.error or "") for r in replies)
    assert service.stats.batches == 0 and len(service.stats.errors) == 1


def test_the_wait_for_the_device_is_not_the_episodes_time() -> None:
    with episode_budget(0.2, 10):
        with budget_paused():
            time.sleep(0.3)
        check_deadline()  # the 0.3 s paused does not count
        with pytest.raises(EpisodeTimeoutError):  # the alarm is armed again after the pause
            time.sleep(0.25)
            check_deadline()


def _stub_batch(scene: Any, jobs: list[Any]) -> list[PickOutcome]:
    return [
        PickOutcome(failure_reason="lift_below_threshold", message="stub device", control_steps=1)
        for _ in jobs
    ]


def test_a_pool_sends_its_mjwarp_jobs_to_the_parents_device(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Two workers plan, the parent's device thread answers their jobs (a stub batch here):
    every executed row carries the device's outcome and the engine's name."""
    original = DeviceService.__init__

    def with_stub(self: DeviceService, waiting: Any, devices: Any = None, execute: Any = None):
        original(self, waiting, devices, _stub_batch)

    monkeypatch.setattr(service_module.DeviceService, "__init__", with_stub)
    episodes = [
        dataclasses.replace(EpisodeSpec(task=fr3(), seed=s, episode_index=s), engine="mjwarp")
        for s in range(4)
    ]
    rows: list[dict[str, Any]] = []
    stats = run_process_pool(episodes, tmp_path, "none", rows.append, workers=2)
    assert stats.finished == 4 and not stats.crashed
    # the stub's verdict: only an episode executed on the device can end with it
    executed = [r for r in rows if r["failure_reason"] == "lift_below_threshold"]
    assert len(executed) == stats.device.jobs >= 3
    assert all(r["error_message"] == "stub device" for r in executed)
    assert all(r["engine"] == "mjwarp" for r in rows)
    assert 1 <= stats.device.largest <= 2


@pytest.mark.slow
@pytest.mark.gpu
@pytest.mark.skipif(not HAS_WARP, reason="needs the 'gpu' extra (pip install .[gpu])")
def test_a_pool_on_warps_cpu_device_gives_the_mujoco_verdicts(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Two FR3 cube episodes planned by two workers and stepped as one MJWarp batch on Warp's
    CPU device: the same reference and validity verdicts as the CPU engine."""
    monkeypatch.setenv("HARNESS_WARP_DEVICE", "cpu")
    monkeypatch.setattr(service_module, "GATHER_S", 120.0)  # both jobs in one batch
    task = fr3().model_copy(update={"limits": fr3().limits.model_copy(update={"wall_time_s": 900})})
    episodes = [EpisodeSpec(task=task, seed=s, episode_index=s) for s in range(2)]
    cpu: list[dict[str, Any]] = []
    run_process_pool(episodes, tmp_path / "cpu", "none", cpu.append, workers=2)
    gpu: list[dict[str, Any]] = []
    on_gpu = [dataclasses.replace(e, engine="mjwarp") for e in episodes]
    stats = run_process_pool(on_gpu, tmp_path / "gpu", "none", gpu.append, workers=2)
    by_seed = {r["seed"]: r for r in cpu}
    assert stats.device.jobs == 2 and stats.device.largest == 2
    for row in gpu:
        twin = by_seed[row["seed"]]
        assert list(row) == list(twin)
        for key in ("success", "failure_reason", "valid", "invalid_reason"):
            assert row[key] == twin[key], key


class _TwoDeviceEngine:
    """A stand-in ``MjwarpEngine``: its slots are names; every batch waits at a barrier."""

    barrier: threading.Barrier | None = None
    entered = threading.Semaphore(0)  # released by each batch as it reaches the device

    def __init__(self, device: str | None = None) -> None:
        self.device = device or "?"

    def slots(self, count: int) -> list[str]:
        return [f"{self.device} slot {k}" for k in range(count)]

    def execute_many(self, scene: Any, jobs: list[Any], slot: Any = None) -> tuple[list, None]:
        assert slot is not None and slot.startswith(self.device)
        assert _TwoDeviceEngine.barrier is not None
        _TwoDeviceEngine.entered.release()
        _TwoDeviceEngine.barrier.wait(timeout=60)
        return [PickOutcome(message=f"{slot}") for _ in jobs], None


def test_two_devices_run_two_batches_each_at_once(
    fr3_jobs, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Two devices of two slots each: four batches are on the devices at the same time (each
    waits at a barrier of four: fewer at once would time out), two on each device, each on a
    slot of its own device."""
    from harness.engines.mjwarp import engine as mjwarp_engine

    monkeypatch.setattr(mjwarp_engine, "MjwarpEngine", _TwoDeviceEngine)
    _TwoDeviceEngine.barrier = threading.Barrier(4)
    service = DeviceService(lambda: 1, devices=["cuda:0", "cuda:1"])
    replies: list[DeviceReply] = []
    done = threading.Semaphore(0)

    def answer(reply: DeviceReply) -> None:
        replies.append(reply)
        done.release()

    for _ in range(4):  # one job at a time, each sent once the one before is on a device
        service.submit(fr3_jobs[0], answer)
        assert _TwoDeviceEngine.entered.acquire(timeout=60)
    for _ in range(4):
        assert done.acquire(timeout=60)
    service.stop()
    assert all(r.outcome is not None for r in replies), [r.error for r in replies]
    slots = sorted(r.outcome.message for r in replies if r.outcome)
    assert slots == ["cuda:0 slot 0", "cuda:0 slot 1", "cuda:1 slot 0", "cuda:1 slot 1"]
    assert service.stats.by_device == {"cuda:0": 2, "cuda:1": 2}
    assert service.stats.batches == 4 and not service.stats.errors


def test_a_second_batch_runs_while_the_first_is_on_the_device(fr3_jobs) -> None:
    """Two slots: the job that arrives while the first batch is on the device runs as a batch
    of its own at the same time (both wait at a barrier: one at a time, it would time out and
    both batches fail), and each job gets its own outcome."""
    barrier = threading.Barrier(2)
    started = threading.Event()
    batches: list[int] = []

    def execute(scene: Any, jobs: list[Any]) -> list[PickOutcome]:
        batches.append(len(jobs))
        started.set()
        barrier.wait(timeout=60)
        return [PickOutcome(message=f"job {id(job)}") for job in jobs]

    service = DeviceService(lambda: 2, execute=execute)
    first, second = fr3_jobs[:2]
    replies: list[DeviceReply] = []
    done = threading.Semaphore(0)

    def answer(reply: DeviceReply) -> None:
        replies.append(reply)
        done.release()

    service.submit(first, answer)
    assert started.wait(timeout=60)  # the first batch (the first job alone) is on the device
    service.submit(second, answer)
    assert done.acquire(timeout=90) and done.acquire(timeout=90)
    service.stop()
    assert batches == [1, 1]
    assert sorted(r.outcome.message for r in replies if r.outcome) == sorted(
        f"job {id(job)}" for job in (first, second)
    )
    assert service.stats.batches == 2 and not service.stats.errors
