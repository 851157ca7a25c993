"""The episode threads a box's device pools may hold come from the kernel's task limits."""

from __future__ import annotations

import resource
from pathlib import Path

import pytest

from harness.runs import thread_budget
from harness.runs.thread_budget import box_episode_threads, read_limit, starved_note, task_limit


def _limits(tmp_path: Path, **values: str) -> tuple[Path, ...]:
    files = []
    for name, text in values.items():
        path = tmp_path / name
        path.write_text(text + "\n")
        files.append(path)
    return tuple(files)


def _no_nproc(monkeypatch: pytest.MonkeyPatch) -> None:
    infinite = (resource.RLIM_INFINITY, resource.RLIM_INFINITY)
    monkeypatch.setattr(thread_budget.resource, "getrlimit", lambda _which: infinite)


def test_the_least_kernel_limit_bounds_the_tasks(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _no_nproc(monkeypatch)
    files = _limits(tmp_path, pid_max="32768", threads_max="192731", pids_max="max")
    assert read_limit(files[2]) is None  # cgroup v2 writes "max" for no limit
    assert read_limit(tmp_path / "absent") is None
    assert task_limit(files) == 32768
    assert box_episode_threads(files) == 16384  # half: the rest for the processes' own threads


def test_rlimit_nproc_counts_too(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(thread_budget.resource, "getrlimit", lambda _which: (4096, 8192))
    files = _limits(tmp_path, pid_max="4194304")
    assert task_limit(files) == 4096
    assert box_episode_threads(files) == 2048


def test_no_readable_limit_keeps_the_measured_default(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _no_nproc(monkeypatch)
    assert task_limit((tmp_path / "none",)) is None
    assert box_episode_threads((tmp_path / "none",)) == thread_budget.UNKNOWN_LIMIT_THREADS
    tiny = _limits(tmp_path, pid_max="20")
    assert box_episode_threads(tiny) == thread_budget.MIN_THREADS


def test_this_box_can_start_its_budget_share() -> None:
    """The budget never exceeds what this box's kernel allows."""
    limit = task_limit()
    budget = box_episode_threads()
    assert limit is None or budget <= limit


def test_a_starved_feed_names_the_limit_to_raise(monkeypatch: pytest.MonkeyPatch) -> None:
    # two GPUs under pid_max 32,768: 8,192 threads a GPU hold one episode for each of 8,192
    # lanes, not the two a lane wants, and the line says what to raise
    monkeypatch.delenv("HARNESS_IN_FLIGHT_PER_LANE", raising=False)
    assert starved_note(8192, 32768) == ""
    note = starved_note(8192, 8192)
    assert "8192 episode threads for 16384 episodes in flight (8192 lanes)" in note
    assert "kernel.pid_max" in note
    assert starved_note(64, 16384) == ""
    # the canonical tune's refinement on one H100: 40,000 episodes, 16,000 lanes
    assert "16384 episode threads for 32000 episodes" in starved_note(16000, 16384, 40000)
    assert starved_note(16000, 16384, 7200) == ""  # its screening fits
