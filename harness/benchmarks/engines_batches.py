"""The engines bench's lockstep-batch side (``BENCH_BATCH``, ``BENCH_BUCKET``, ``BENCH_SLOTS``):
one engine per device, several batches in flight per device, where the device's time went. Its
lane streams (``BENCH_LANES``) are the product's ``harness.engines.mjwarp.devices.DeviceStreams``.
"""

from __future__ import annotations

import os
import queue
import threading
import time
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any

from harness.engines.mjwarp.busy_time import union_length
from harness.engines.mjwarp.devices import DeviceStreams
from harness.engines.mjwarp.stream_keys import scene_for
from harness.pick.outcome import PickOutcome


def batch_key(job: Any) -> str:
    """The bench's lockstep batches hold jobs of one task."""
    return job.task.model_dump_json()


class GpuDevices:
    """The bench's lockstep batches: one engine per device (``device``: one name, or several
    separated by commas), its scenes, the outcomes by episode index and where its time went.
    ``step`` hands a batch to one of ``BENCH_SLOTS`` (default 2) threads per device, each with a
    stream of its own (``DeviceSlot``), the slots taken in turn across the devices: one batch's
    host work (upload, tug rounds, judging) overlaps another's physics; ``drain`` waits for
    them all. Lane streams (``BENCH_LANES``) go through ``DeviceStreams`` (``to_stream``)."""

    def __init__(self, device: str) -> None:
        from harness.engines.mjwarp.engine import MjwarpEngine

        # BENCH_BUFFERS=contacts,rows: the per-world buffers (default steps.SMALL)
        sizes = os.environ.get("BENCH_BUFFERS")
        buffers = None
        if sizes:
            contacts, rows = (int(v) for v in sizes.split(","))
            buffers = (contacts, rows)
        # BENCH_RETIRE=share: when finished worlds leave a batch's motion (0: lockstep)
        retire = os.environ.get("BENCH_RETIRE")
        # one engine per device ("cuda:0,cuda:1": several)
        self.engines = [
            MjwarpEngine(name, buffers, float(retire) if retire else None)
            for name in device.split(",")
        ]
        self.scenes: dict[Any, Any] = {}
        self.outcomes: dict[int, PickOutcome] = {}
        self.totals = {
            "upload_s": 0.0, "physics_s": 0.0, "tug_s": 0.0, "download_s": 0.0,
            "judge_s": 0.0, "tug_rounds": 0.0, "tug_rungs": 0.0, "reruns": 0.0,
        }  # fmt: skip
        self.counts = {
            "world_steps": 0, "motion_steps": 0, "span_steps": 0, "max_batch": 0, "batches": 0,
        }  # fmt: skip
        self.peaks = {"peak_rows": 0.0, "peak_contacts": 0.0, "memory_high_gb": 0.0}
        self.compile_s = 0.0
        self.slots: queue.Queue[tuple[Any, Any]] = queue.Queue()  # (engine, slot), free
        per_device = [
            engine.slots(int(os.environ.get("BENCH_SLOTS", "2"))) for engine in self.engines
        ]
        for k in range(len(per_device[0])):  # in turn across the devices
            for engine, slots in zip(self.engines, per_device, strict=True):
                self.slots.put((engine, slots[k]))
        self.slot_count = self.slots.qsize()
        self.threads = ThreadPoolExecutor(self.slot_count)
        self.pending: list[Future[None]] = []
        self.busy: list[tuple[float, float]] = []  # (start, end) of each batch
        self.streams: DeviceStreams | None = None  # lane streams (BENCH_LANES), at first use
        self.lock = threading.Lock()

    @property
    def device_s(self) -> float:
        """Wall time with at least one batch (or stream) on the device."""
        if self.streams is not None:
            return self.streams.stats.device_s
        return union_length(self.busy)

    def _scene(self, job: Any) -> Any:
        return scene_for(job.task, self.scenes, self.lock, job.contact)

    def load(self, jobs: list[Any]) -> None:
        """Load (compile) the kernels of each task model among ``jobs``, off the clock."""
        seen: set[str] = set()
        for job in jobs:
            if job is not None and batch_key(job) not in seen:
                seen.add(batch_key(job))
                clock = time.perf_counter()
                for engine in self.engines:
                    engine.execute_many(self._scene(job), [job])
                self.compile_s += time.perf_counter() - clock

    def warm_lanes(self, job: Any) -> None:
        """Compile the lanes' kernels and capture their graph once, off the clock."""
        from harness.engines.mjwarp.stream import LaneStream

        for engine in self.engines:
            batch = engine.batch(self._scene(job), job.task, contact=job.contact)
            items: list[Any] = [[(0, job)], None]
            LaneStream(batch, nlane=1, group=1).run(lambda block, want, items=items: items.pop(0))

    def to_stream(self, index: int, job: Any, lanes: int) -> None:
        """Hand a planned job to the lane streams (the product's ``DeviceStreams``, on this
        bench's engines), its outcome kept under ``index``."""
        if self.streams is None:
            engines = {engine.device: engine for engine in self.engines}
            self.streams = DeviceStreams(list(engines), lanes, make_engine=engines.__getitem__)

        def answer(outcome: PickOutcome | None, error: str | None) -> None:
            if outcome is not None:
                with self.lock:
                    self.outcomes[index] = outcome

        self.streams.submit(index, job, answer)

    def close_streams(self) -> None:
        """No more jobs: the streams drain and end; their timings are counted in."""
        if self.streams is None:
            return
        self.streams.close()
        stats = self.streams.stats
        if stats.errors:
            raise RuntimeError(f"lane streams failed: {stats.errors[0]}")
        if stats.timings is not None:
            self._add(stats.timings, stats.lanes)
        self.counts["batches"] = stats.streams

    def step(self, indices: list[int], jobs: list[Any]) -> None:
        """Queue one batch of worlds; its outcomes are kept under the episodes' indices."""
        self._scene(jobs[0])  # made here, in one thread
        self.pending.append(self.threads.submit(self._step, indices, jobs))

    def in_flight(self) -> int:
        """Batches handed to the slots and not finished."""
        return sum(not future.done() for future in self.pending)

    def drain(self) -> None:
        for future in self.pending:
            future.result()
        self.pending.clear()

    def _step(self, indices: list[int], jobs: list[Any]) -> None:
        engine, slot = self.slots.get()
        try:
            clock = time.perf_counter()
            result, timings = engine.execute_many(self._scene(jobs[0]), jobs, slot)
            span = (clock, time.perf_counter())
        finally:
            self.slots.put((engine, slot))
        with self.lock:
            self.busy.append(span)
            for i, outcome in zip(indices, result, strict=True):
                self.outcomes[i] = outcome
            self._add(timings, len(jobs))

    def _add(self, timings: Any, worlds: int) -> None:
        """Count a batch's (or the streams') timings in."""
        for key in self.totals:
            self.totals[key] += getattr(timings, key)
        for key in ("world_steps", "motion_steps", "span_steps"):
            self.counts[key] += getattr(timings, key)
        self.counts["max_batch"] = max(self.counts["max_batch"], worlds)
        self.counts["batches"] += 1
        for key in ("peak_rows", "peak_contacts"):
            self.peaks[key] = max(self.peaks[key], float(getattr(timings, key)))
        self.peaks["memory_high_gb"] = sum(e.memory_high_gb() for e in self.engines)
