"""The sampling profiler (harness.runs.sampler): a thread busy in one function shows up
at the top of the table, on its own stack and at its top; the table goes to the named file."""

from __future__ import annotations

import threading
import time
from pathlib import Path

from harness.runs.sampler import Sampler


def _spin_until(done: threading.Event, started: threading.Event) -> None:
    started.set()
    while not done.is_set():
        sum(range(200))


def test_a_busy_thread_leads_the_table(tmp_path: Path) -> None:
    """The thread is busy for the whole sampled window, as every other thread of the process
    lives through it (pytest-xdist's execnet thread did, and once read twice the samples of a
    thread busy for only part of the window)."""
    ticks: list[int] = []
    sampler = Sampler(interval_s=0.002, on_tick=lambda s: ticks.append(s.samples), tick_s=0.1)
    done, started = threading.Event(), threading.Event()
    worker = threading.Thread(target=_spin_until, args=(done, started))
    worker.start()
    assert started.wait(timeout=30)
    sampler.start()
    time.sleep(0.5)
    sampler.stop()
    done.set()
    worker.join()
    name = next(n for n in sampler.inclusive if n.endswith(" _spin_until"))
    assert sampler.inclusive[name] >= 0.5 * max(sampler.inclusive.values())
    assert sampler.own[name] > 0  # builtins make no frame: the loop itself is on top
    assert ticks and ticks == sorted(ticks)
    assert name in sampler.table()
