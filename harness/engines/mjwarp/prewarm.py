"""Loading a run's device models before its first job arrives.

A stream's first use of a task model on a device loads every MuJoCo Warp module its step
launches (from Warp's kernel cache when it holds them, else compiling them) and makes the
device model. ``prewarm`` does it in a background thread as soon as the run's tasks are known,
while the planning workers start, so the first stream finds the model and the modules ready.
Measured gain small: the FR3 cube sweep's first outcome came after 24.3 s with it (H100) and
25.2 s without (H200), 2026-11-27; the first outcome is mostly the workers' start and one
episode span. It changes no result: the stream makes the same device model
(``MjwarpEngine.batch`` keeps it) and a one-world step's state is thrown away.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable
from typing import Any

import mujoco_warp as mjw
import warp as wp

from harness.engines.mjwarp import kernels
from harness.engines.mjwarp import lane_kernels as lk
from harness.engines.mjwarp.slot import HOST_LOCK


def warm_model(engine: Any, scene: Any, task: Any) -> None:
    """``task``'s device model on ``engine``'s device, and one eager step of one world (which
    loads the modules of every kernel the step launches), on a device stream of its own (so it
    neither waits for nor orders the lane streams' work) under the host lock."""
    with HOST_LOCK:  # a stream is a Warp call: Warp's current device is process-wide
        (slot,) = engine.slots(1)
    batch = engine.batch(scene, task, slot)
    dm = batch.dm
    with slot, wp.ScopedDevice(dm.device):
        d = batch.data(1, batch.buffers)
        mjw.step(dm.model, d)
        for module in (kernels, lk):
            wp.load_module(module, device=dm.device)
        slot.wait()


def prewarm(
    jobs: Iterable[tuple[Any, Any]],
    warm: Callable[[Any, Any], None],
    on_error: Callable[[str], None],
) -> threading.Thread:
    """Run ``warm(device, task)`` for each (device, task) of ``jobs`` in a daemon thread;
    a failure is reported with ``on_error`` and left to the stream (which fails as before)."""

    def run() -> None:
        for device, task in jobs:
            try:
                warm(device, task)
            except Exception as exc:  # the stream meets it again and answers its jobs
                on_error(f"preparing {task.name} on {device}: {type(exc).__name__}: {exc}")

    thread = threading.Thread(target=run, name="mjwarp-prewarm", daemon=True)
    thread.start()
    return thread
