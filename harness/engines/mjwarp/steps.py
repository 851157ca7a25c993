"""Stepping worlds on a MuJoCo Warp device: per-world buffer sizes and their use, where a
batch's time went, and one step or a replayed CUDA graph of steps.

``stepper`` and ``replay`` are looked up through this module by the motion and the tug (and
replaced there by ``harness.benchmarks.device_profile`` to time a few steps eagerly).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import mujoco_warp as mjw
import numpy as np
import warp as wp

from harness.engines.mjwarp import kernels
from harness.engines.mjwarp.graph_loop import LoopGraph, try_loop_steps
from harness.engines.mjwarp.graph_plan import graph_plan
from harness.engines.mjwarp.host import to_host
from harness.engines.mjwarp.schedule import DeviceJob, ExecutionSchedule


@dataclass(frozen=True)
class Buffers:
    """What MuJoCo Warp allocates per world: contacts (``nconmax``; pooled over the batch's
    worlds) and constraint rows (``njmax``; no world may use more). Every solver kernel is
    launched over ``njmax`` rows per world, so the rows cost step time and memory even unused."""

    nconmax: int
    njmax: int


# Sized from the CPU engine's peak use (``MjData.maxuse_con`` / ``maxuse_efc``) over 12 seeds of
# each canonical arm with the cube and the banana, tug included: at most 25 contacts and 106
# constraint rows (elliptic cones) in a world; about 2.5x that room. Chosen, no public source
# (MJWarp's own default for these models, ``io._default_nconmax`` / ``_default_njmax``, would be
# 48 / 64). A world that asks for more is run again with ``LARGE``.
SMALL = Buffers(nconmax=64, njmax=256)
LARGE = Buffers(nconmax=128, njmax=768)  # the sizes used before; the fallback


@dataclass
class BatchTimings:
    """Where a batch's wall time went (s), its world-steps, and its tug rounds and rung-worlds
    (one world per rung run)."""

    upload_s: float = 0.0
    physics_s: float = 0.0
    tug_s: float = 0.0
    tug_issue_s: float = 0.0  # of ``tug_s``: making the rounds' data and issuing their steps
    download_s: float = 0.0
    judge_s: float = 0.0  # the verdicts on the host (``judge``), after the download
    world_steps: int = 0  # every world-step stepped: the motion's (padding included) and the tug's
    motion_steps: int = 0  # the motion's world-steps: every world stepped for the longest span
    span_steps: int = 0  # of those, the ones within each world's own span (the rest: padding)
    tug_rounds: int = 0
    tug_rungs: int = 0
    peak_rows: int = 0  # the most constraint rows a world asked for
    peak_contacts: float = 0.0  # the most contacts per world of a batch, on average
    reruns: int = 0  # worlds run again with the ``LARGE`` buffers (their rows did not fit)
    # a lane stream's host visits (one replay of its graph each), and of its ``physics_s`` the
    # time in the graph launches and waiting for its stream (the rest: judging meanwhile)
    visits: int = 0
    launch_s: float = 0.0
    wait_s: float = 0.0
    loop_graphs: int = 0  # graphs captured as device-side loops (``graph_loop``)


class BufferUse:
    """Each world's peak constraint rows and the batch's peak contacts on the device
    (``kernels.track_use`` after every physics step), and which worlds did not fit."""

    def __init__(self, nworld: int) -> None:
        self.rows = wp.zeros(nworld, dtype=wp.int32)
        self.contacts = wp.zeros(1, dtype=wp.int32)

    def track(self, d: mjw.Data) -> None:
        wp.launch(
            kernels.track_use, dim=d.nworld, inputs=[d.nefc, d.nacon, self.rows, self.contacts]
        )

    def overflowed(self, d: mjw.Data, buffers: Buffers, timings: BatchTimings) -> list[int]:
        """The worlds whose rows or contacts did not fit (every world when the batch's contact
        pool overflowed: which world lost a contact is not known); notes the peaks."""
        rows = to_host(self.rows)
        contacts = int(to_host(self.contacts)[0])
        timings.peak_rows = max(timings.peak_rows, int(rows.max(initial=0)))
        timings.peak_contacts = max(timings.peak_contacts, contacts / max(1, d.nworld))
        if contacts > d.naconmax:
            return list(range(d.nworld))
        return [int(w) for w in np.flatnonzero(rows > buffers.njmax)]


def stepper(model: mjw.Model, d: mjw.Data, use: BufferUse):  # type: ignore[no-untyped-def]
    """One physics step of every world of ``d``, its buffer use noted."""

    def step() -> None:
        mjw.step(model, d)
        use.track(d)

    return step


def launch_in_place(graph: Any, times: int = 1) -> None:
    """Replay ``graph`` ``times`` times on the device's current stream."""
    for _ in range(times):
        wp.capture_launch(graph)


def replay(  # type: ignore[no-untyped-def]
    device: str, fn, times: int, launch=launch_in_place, per_graph: int = 1, looped: bool = False
) -> LoopGraph | None:
    """Run ``fn`` ``times`` times: the first eagerly (loads the kernels), the rest as replays of
    captured CUDA graphs of ``per_graph`` calls each (``graph_plan``) with
    ``launch(graph, times)`` (the slot's: ``DeviceSlot.launch``; on the CPU device: eagerly), or
    with ``looped`` (``graph_loop``) one more eager call and one launch of a graph looping over
    ``fn`` on the device (returned: the caller keeps it, with its counter and scratch, until
    that work is done)."""
    if times <= 0:
        return None
    fn()
    if times == 1:
        return None
    if not wp.get_device(device).is_cuda:
        for _ in range(times - 1):
            fn()
        return None
    if looped and times >= 3:  # one more eager call, then the rest as one device-side loop
        loop = try_loop_steps(device, fn, times - 2)
        if loop is not None:
            launch(loop.graph, 1)
            return loop
        times -= 1  # its recording call ran; the rest unrolled
    for calls, launches in graph_plan(times, per_graph):
        with wp.ScopedCapture(device=device) as capture:
            for _ in range(calls):
                fn()
        graph = capture.graph
        assert graph is not None
        launch(graph, launches)
    return None


def world_arrays(jobs: list[DeviceJob]) -> dict[str, np.ndarray]:
    return {name: np.stack([job.state[name] for job in jobs]) for name in jobs[0].state}


def schedule_rows(schedules: list[ExecutionSchedule], rows: int) -> tuple[np.ndarray, np.ndarray]:
    """(world, rows * chunks, nu) controls, each world's padded with its held controls."""
    nchunks = len(schedules[0].chunk_sizes)
    nu = schedules[0].ctrl.shape[2]
    table = np.empty((len(schedules), rows * nchunks, nu), dtype=np.float32)
    last = np.empty(len(schedules), dtype=np.int32)
    for w, schedule in enumerate(schedules):
        flat = schedule.ctrl.reshape(-1, nu)
        table[w, : len(flat)] = flat
        table[w, len(flat) :] = schedule.hold_ctrl
        last[w] = len(flat) - 1
    return table, last
