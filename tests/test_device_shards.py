"""A process per device (``harness.runs.device_shards``): share groups split whole between the
devices, planning workers in proportion, stats summed, a dead device process's episodes stored
as ``error`` rows, a stop that keeps what finished; slow, on Warp's CPU device: two device
processes give the rows of one lockstep batch."""

from __future__ import annotations

import dataclasses
import importlib.util
import queue
from pathlib import Path
from typing import Any

import pytest

from harness.config import apply_overrides, load_task
from harness.engines.mjwarp.stream_stats import StreamStats
from harness.episode import EpisodeSpec
from harness.objects.assets import repo_root
from harness.runs.device_shards import (
    _collect,
    _Shard,
    merge_stats,
    process_per_device,
    split_groups,
    split_workers,
)
from harness.runs.executors import RunStats
from harness.runs.scheduling import share_groups

HAS_WARP = importlib.util.find_spec("mujoco_warp") is not None


def _fr3_cones(seeds: int) -> list[EpisodeSpec]:
    """FR3 at three approach cones x ``seeds`` seeds: share groups of three (one per seed)."""
    base = load_task(repo_root() / "tasks" / "pick" / "fr3.yaml")
    episodes = []
    for point_id, cone in enumerate((100.0, 140.0, 160.0)):
        point = {"pick.filter_z_dir": ["downward", cone]}
        task = apply_overrides(base, point)
        episodes += [
            EpisodeSpec(
                task=task, seed=s, episode_index=s, point_id=point_id, point=point, engine="mjwarp"
            )
            for s in range(seeds)
        ]
    return episodes


def test_share_groups_go_whole_to_the_emptiest_device() -> None:
    episodes = _fr3_cones(5)  # 5 groups of 3
    split = split_groups(episodes, 2)
    assert [len(part) for part in split] == [9, 6]
    assert sorted(e.resolved_id for part in split for e in part) == sorted(
        e.resolved_id for e in episodes
    )
    for part in split:  # every group whole in one part: the part's groups are all of size 3
        assert [len(g) for g in share_groups(part)] == [3] * (len(part) // 3)
    assert [len(part) for part in split_groups(episodes, 2, share=False)] == [8, 7]
    assert split_groups(episodes[::5], 2)[1] == []  # seed 0 alone: the other device gets none


def test_planning_workers_follow_the_shards_sizes() -> None:
    assert split_workers(31, [9, 6]) == [19, 12]
    assert split_workers(31, [1000, 1000]) == [16, 15]
    assert split_workers(1, [5, 5]) == [1, 1]  # each shard plans with at least one
    assert sum(split_workers(15, [7, 3, 5])) == 15


def test_a_process_per_device_for_a_large_run_or_when_asked(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Several devices get a process each when each has a stream's worth of episodes (the
    45,000-row sweep on two H200s: 1.6x one), not for a tune's race round of a few thousand
    (one process keeps its device models between rounds); ``HARNESS_PROCESS_PER_DEVICE`` 1 or 0
    decides instead."""
    from harness.runs.device_shards import SHARD_MIN_EPISODES

    monkeypatch.delenv("HARNESS_PROCESS_PER_DEVICE", raising=False)
    two = ["cuda:0", "cuda:1"]
    assert not process_per_device(["cuda:0"], 10**6)
    assert process_per_device(two, 45_000)
    assert process_per_device(two, 2 * SHARD_MIN_EPISODES)
    assert not process_per_device(two, 7_012)  # the canonical tune's first race round
    monkeypatch.setenv("HARNESS_PROCESS_PER_DEVICE", "1")
    assert process_per_device(two, 3) and not process_per_device(["cuda:0"], 10**6)
    monkeypatch.setenv("HARNESS_PROCESS_PER_DEVICE", "0")
    assert not process_per_device(two, 45_000)


def test_the_shards_stats_add_up() -> None:
    total = RunStats(finished=3, errors=["a"])
    first = StreamStats(jobs=5, streams=2, lanes=64, device_s=10.0, by_device={"cuda:0": 2})
    first.jobs_by_device = {"cuda:0": 5}
    assert first.spread() == ""  # one device: nothing to compare
    second = StreamStats(jobs=7, streams=1, lanes=128, device_s=12.5, by_device={"cuda:1": 1})
    second.jobs_by_device = {"cuda:1": 7}
    merge_stats(total, RunStats(finished=4, crashed=1, device=first))
    merge_stats(total, RunStats(finished=6, interrupted=True, errors=["b"], device=second))
    assert (total.finished, total.crashed, total.interrupted) == (13, 1, True)
    assert total.errors == ["a", "b"]
    device = total.device
    assert (device.jobs, device.streams, device.lanes) == (12, 3, 128)
    assert device.device_s == 12.5  # side by side: the longest shard's
    assert device.by_device == {"cuda:0": 2, "cuda:1": 1}
    assert device.jobs_by_device == {"cuda:0": 5, "cuda:1": 7}
    assert device.spread() == " (cuda:0: 2 stream(s), 5 job(s); cuda:1: 1 stream(s), 7 job(s))"


class _Process:
    """A shard process that has ended with ``exitcode``."""

    def __init__(self, exitcode: int | None) -> None:
        self.exitcode = exitcode
        self.terminated = False

    def terminate(self) -> None:
        self.terminated = True


def test_a_dead_device_process_leaves_an_error_row_per_episode_it_had_not_finished() -> None:
    """Shard 0 sends one row then dies (SIGKILL); shard 1 finishes. Every episode has exactly
    one row: shard 0's other two are ``error`` rows naming its device."""
    episodes = _fr3_cones(1)
    first = _Shard("cuda:0", episodes, _Process(-9))
    second = _Shard("cuda:1", [], _Process(0))
    out: queue.Queue[Any] = queue.Queue()
    out.put((0, {"episode_id": episodes[0].resolved_id, "failure_reason": ""}))
    out.put((1, RunStats(finished=0)))
    rows: list[dict[str, Any]] = []
    stats = RunStats()
    _collect([first, second], out, rows.append, stats, deadline=None)
    assert sorted(r["episode_id"] for r in rows) == sorted(e.resolved_id for e in episodes)
    lost = [r for r in rows if r["failure_reason"] == "error"]
    assert len(lost) == 2 and stats.crashed == 2
    assert all("device process of cuda:0 died (exit code -9)" in r["error_message"] for r in lost)


def test_a_stop_keeps_the_rows_sent_and_ends_a_shard_that_overstays() -> None:
    episodes = _fr3_cones(1)
    shard = _Shard("cuda:0", episodes, _Process(None))  # still running, never reports
    out: queue.Queue[Any] = queue.Queue()
    out.put((0, {"episode_id": episodes[0].resolved_id, "failure_reason": ""}))
    rows: list[dict[str, Any]] = []
    _collect([shard], out, rows.append, RunStats(), deadline=0.0)  # the grace is already over
    assert shard.process.terminated  # past the deadline: ended, and what it sent is kept
    assert [r["episode_id"] for r in rows] == [episodes[0].resolved_id]
    shard = _Shard("cuda:0", episodes, _Process(None))
    out.put((0, {"episode_id": episodes[1].resolved_id, "failure_reason": ""}))
    out.put((0, RunStats(finished=1, interrupted=True)))
    stats = RunStats()
    _collect([shard], out, rows.append, stats, deadline=float("inf"))
    assert [r["episode_id"] for r in rows] == [e.resolved_id for e in episodes[:2]]
    assert stats.interrupted and not shard.process.terminated


def _answer_every_job(engine: Any, scene: Any, source: Any, on_outcome: Any, lanes: int) -> None:
    """A stand-in lane stream: every job it takes is answered at once with a stub outcome."""
    from harness.pick.outcome import PickOutcome

    while (items := source(True)) is not None:
        for tag, _ in items:
            on_outcome(tag, PickOutcome(failure_reason="lift_below_threshold", control_steps=1))


@pytest.fixture
def stub_device(monkeypatch: pytest.MonkeyPatch) -> None:
    """``DeviceService`` on the stand-in stream; the shard's signal handlers put back after."""
    import signal

    from harness.engines.mjwarp import service

    original = service.DeviceService.__init__

    def with_stub(self: Any, devices: Any = None, **streams: Any) -> None:
        original(self, ["stub"], lanes=4, make_engine=lambda d: d, run_stream=_answer_every_job)

    monkeypatch.setattr(service.DeviceService, "__init__", with_stub)
    monkeypatch.setenv("HARNESS_WARP_DEVICE", "cpu")  # the shard sets its own; put back after
    monkeypatch.setenv("HARNESS_PROCESS_PER_DEVICE", "1")
    handlers = {n: signal.getsignal(n) for n in (signal.SIGINT, signal.SIGUSR1)}
    yield
    for number, handler in handlers.items():
        signal.signal(number, handler)


def test_a_shard_sends_each_row_then_its_stats(tmp_path: Path, stub_device: None) -> None:
    """A shard's pool (in this process, on the stand-in device): every episode's row, each
    tagged with the shard's index, then its ``RunStats``."""
    import threading

    from harness.runs.device_shards import shard_main

    episodes = _fr3_cones(1)
    out: queue.Queue[Any] = queue.Queue()
    shard_main(1, "cuda:1", episodes, str(tmp_path), "none", 1, True, out, threading.Event(), 64)
    messages = [out.get_nowait() for _ in range(out.qsize())]
    assert {index for index, _ in messages} == {1}
    rows, stats = [m for _, m in messages[:-1]], messages[-1][1]
    assert sorted(r["episode_id"] for r in rows) == sorted(e.resolved_id for e in episodes)
    assert isinstance(stats, RunStats) and stats.finished == 3 and not stats.interrupted
    assert stats.device.jobs >= 1 and all(r["engine"] == "mjwarp" for r in rows)


class _StopOnFirstRow(queue.Queue):
    """The shard's queue to the parent; the parent's stop is set when the first row comes."""

    def __init__(self, stop: Any) -> None:
        super().__init__()
        self.stop = stop

    def put(self, item: Any, block: bool = True, timeout: float | None = None) -> None:
        super().put(item, block, timeout)
        self.stop.set()


def test_a_stopped_shard_ends_its_pool_and_says_so(tmp_path: Path, stub_device: None) -> None:
    """The parent's stop (after Ctrl-C), set here once the shard's first row came: the pool
    ends as Ctrl-C would end it, its stats say interrupted, and it sent a row only for the
    episodes it finished. A stop before the pool starts runs nothing."""
    import threading

    from harness.runs.device_shards import shard_main

    episodes = _fr3_cones(4)
    stop = threading.Event()
    out = _StopOnFirstRow(stop)
    shard_main(0, "cuda:0", episodes, str(tmp_path), "none", 1, True, out, stop, 64)
    messages = [out.get_nowait() for _ in range(out.qsize())]
    stats = messages[-1][1]
    assert isinstance(stats, RunStats) and stats.interrupted
    assert 1 <= len(messages) - 1 == stats.finished < len(episodes)
    early: queue.Queue[Any] = queue.Queue()
    stopped = threading.Event()
    stopped.set()
    shard_main(0, "cuda:0", episodes, str(tmp_path / "early"), "none", 1, True, early, stopped, 64)
    assert early.qsize() == 1
    index, stats = early.get_nowait()
    assert index == 0 and stats.interrupted and stats.finished == 0


@pytest.mark.slow
@pytest.mark.gpu
@pytest.mark.skipif(not HAS_WARP, reason="needs the 'gpu' extra (pip install .[gpu])")
def test_two_device_processes_give_the_rows_of_one(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """FR3 seeds 0-2 on two Warp CPU devices (``HARNESS_WARP_DEVICE=cpu,cpu``, a process each:
    groups 2 + 1, one planning worker each) and on one: the same rows, field for field, with
    the device stats summed over both processes."""
    from harness.runs.executors import run_process_pool

    base = load_task(repo_root() / "tasks" / "pick" / "fr3.yaml")
    task = base.model_copy(update={"limits": base.limits.model_copy(update={"wall_time_s": 60})})
    episodes = [EpisodeSpec(task=task, seed=s, episode_index=s, engine="mjwarp") for s in range(3)]
    monkeypatch.setenv("HARNESS_LANES", "2")
    monkeypatch.setenv("HARNESS_WARP_DEVICE", "cpu,cpu")
    monkeypatch.setenv("HARNESS_PROCESS_PER_DEVICE", "1")  # three episodes: a process each
    two: list[dict[str, Any]] = []
    stats = run_process_pool(episodes, tmp_path / "two", "none", two.append, workers=2)
    assert stats.finished == 3 and not stats.device.errors and stats.device.jobs == 3
    assert stats.device.by_device == {"cpu": 2}  # a stream in each process
    monkeypatch.setenv("HARNESS_WARP_DEVICE", "cpu")
    one: list[dict[str, Any]] = []
    run_process_pool(episodes, tmp_path / "one", "none", one.append, workers=2)
    assert sorted(r["seed"] for r in two) == [0, 1, 2]
    by_seed = {r["seed"]: r for r in one}
    for row in two:
        twin = by_seed[row["seed"]]
        assert row["failure_reason"] != "timeout"
        for column in ("success", "valid", "failure_reason", "lift_height_m", "chosen_index"):
            assert row[column] == twin[column] or row[column] != row[column], column
    assert dataclasses.asdict(stats)["interrupted"] is False
