"""The engines bench's GPU path without a GPU: planning overlapped with device batches (the
device's ``execute_many`` is a stub here; the real one is measured on the GPU box)."""

from __future__ import annotations

from typing import Any, ClassVar

import pytest

from harness.benchmarks import engines as bench
from harness.engines import mjwarp_engine
from harness.pick.outcome import PickOutcome


class _Timings:
    upload_s = physics_s = tug_s = download_s = judge_s = 0.0
    world_steps = tug_rounds = tug_rungs = 0


class _StubEngine:
    batches: ClassVar[list[int]] = []
    lengths: ClassVar[list[list[int]]] = []

    def __init__(self, device: str | None = None) -> None:
        pass

    def execute_many(self, scene: Any, jobs: list[Any]) -> tuple[list[PickOutcome], Any]:
        _StubEngine.batches.append(len(jobs))
        _StubEngine.lengths.append([job.schedule.steps for job in jobs])
        timings = _Timings()
        timings.world_steps = len(jobs)
        return [PickOutcome(success=True, message="stub") for _ in jobs], timings


def test_planned_jobs_are_stepped_in_batches_while_the_pool_plans(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(mjwarp_engine, "MjwarpEngine", _StubEngine)
    _StubEngine.batches, _StubEngine.lengths = [], []
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
