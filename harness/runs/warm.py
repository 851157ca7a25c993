"""Compile a sweep's device kernels once, visibly: ``harness compile TASK_OR_SWEEP``.

Warp compiles MuJoCo Warp's kernels (and this engine's) the first time a task model runs on a
device (NVRTC on a GPU: 200-290 s for the first FR3 model on an H100; Warp's CPU compiler: a
few minutes on 2 cores) and keeps them in its kernel cache (``WARP_CACHE_PATH``, default
``~/.cache/warp``), from which later runs load them in seconds. ``warm`` plans one episode of
each task model among the given episodes (its job: ``plan_job``; and the same job on the
table-physical variant the table verdict replays on, ``harness.episode.table_verdict``), runs
it on every device as a lockstep batch (the batch and tug kernels) and through a one-lane
stream (the lanes' kernels, and a captured graph), and says per model how long that took. A
sweep started afterwards starts stepping at once; the episode wall limit never counts compile
time either way (the device wait is not the episode's: ``harness.engines.mjwarp.service``).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from typing import Any

from harness.engines.base import Execution, ExecutionJob
from harness.pick.outcome import PickOutcome
from harness.pick.validity import validity_enabled


class _Collector:
    """An engine that keeps the job (as a ``DeviceJob``) instead of executing it."""

    name = "collect"

    def __init__(self) -> None:
        self.jobs: list[Any] = []

    def execute(self, job: ExecutionJob) -> Execution:
        from harness.engines.mjwarp.schedule import device_job

        self.jobs.append(device_job(job))
        outcome = PickOutcome(failure_reason="error", message="collected for the device")
        return Execution(outcome, validity_enabled(job.task.pick))


_COLLECTOR = _Collector()


def plan_job(spec: Any, scenes: dict[Any, Any]) -> tuple[dict[str, Any], Any]:
    """Plan one episode up to its execution: its row (when it ended before the execution) and
    its ``DeviceJob`` (None then); no viewer trace (nothing reads it)."""
    from harness.engines import register_engine
    from harness.episode import run_episode

    register_engine(_COLLECTOR)
    _COLLECTOR.jobs.clear()
    row = run_episode(dataclasses.replace(spec, engine="collect", trace=False), scenes).row
    return row, (_COLLECTOR.jobs[0] if _COLLECTOR.jobs else None)


def model_jobs(episodes: list[Any], seeds: int = 8) -> list[Any]:
    """One planned job per stream key (task model and timing) among ``episodes``: the first
    of up to ``seeds`` episodes of each that reaches its execution. (No table-physical
    variant: the table verdict's replays run on the CPU engine, ``table_verdict.
    REPLAY_ENGINE``.)"""
    from harness.engines.mjwarp.devices import stream_key
    from harness.sim import scene_key

    scenes: dict[Any, Any] = {}
    by_model: dict[Any, list[Any]] = {}
    for spec in episodes:
        task = spec.task
        by_model.setdefault((scene_key(task), task.target_object.name), []).append(spec)
    jobs: dict[Any, Any] = {}
    for specs in by_model.values():
        for spec in specs[:seeds]:
            _, job = plan_job(spec, scenes)
            if job is not None:
                jobs.setdefault(stream_key(job), job)
                break
    return list(jobs.values())


def warm(jobs: list[Any], devices: list[str], say: Callable[[str], None]) -> dict[str, float]:
    """Run each job on each device as a lockstep batch and through a one-lane stream; the
    seconds each (device, model) took, said as they finish."""
    from harness.engines.mjwarp.engine import MjwarpEngine
    from harness.engines.mjwarp.stream import LaneStream
    from harness.episode.scene_cache import get_scene

    scenes: dict[Any, Any] = {}
    spent: dict[str, float] = {}
    total = len(jobs) * len(devices)
    k = 0
    for device in devices:
        engine = MjwarpEngine(device)
        for job in jobs:
            k += 1
            task = job.task
            scene = get_scene(task, scenes).scene
            name = f"{task.robot} {task.target_object.name} on {device}"  # both arms' model
            say(f"[{k}/{total}] {name}: compiling or loading its kernels ...")
            clock = time.perf_counter()
            engine.execute_many(scene, [job])
            items: list[Any] = [[(0, job)], None]
            LaneStream(engine.batch(scene, task, contact=job.contact), nlane=1, group=1).run(
                lambda block, want, items=items: items.pop(0)
            )
            spent[name] = time.perf_counter() - clock
            say(f"[{k}/{total}] {name}: ready in {spent[name]:.1f} s")
    return spent
