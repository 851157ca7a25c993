"""The sampling profiler (harness.benchmarks.sampler): a thread busy in one function shows up
at the top of the table, on its own stack and at its top; the table goes to the named file."""

from __future__ import annotations

import threading
import time
from pathlib import Path

from harness.benchmarks.sampler import Sampler


def _spin_for(seconds: float) -> None:
    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        sum(range(200))


def test_a_busy_thread_leads_the_table(tmp_path: Path) -> None:
    ticks: list[int] = []
    sampler = Sampler(interval_s=0.002, on_tick=lambda s: ticks.append(s.samples), tick_s=0.1)
    sampler.start()
    worker = threading.Thread(target=_spin_for, args=(0.5,))
    worker.start()
    worker.join()
    sampler.stop()
    name = next(n for n in sampler.inclusive if n.endswith(" _spin_for"))
    assert sampler.inclusive[name] >= 0.5 * max(sampler.inclusive.values())
    assert sampler.own[name] > 0  # builtins make no frame: the loop itself is on top
    assert ticks and ticks == sorted(ticks)
    assert name in sampler.table()
