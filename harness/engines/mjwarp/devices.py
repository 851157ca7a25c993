"""The device side of the engines bench's GPU path: one engine per device, its slots, and
the batches (or lane streams) handed to them, with where the device's time went."""

from __future__ import annotations

import os
import queue
import threading
import time
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any

from harness.engines.mjwarp.busy_time import union_length
from harness.pick.outcome import PickOutcome


def batch_key(job: Any) -> str:
    """Jobs of one task model share a batch (or a stream)."""
    return job.task.model_dump_json()


class GpuDevices:
    """The device side of the GPU path: one engine per device (``device``: one name, or
    several separated by commas), its scenes, the outcomes by episode index and where its time
    went. ``step`` hands a batch to one of ``BENCH_SLOTS`` (default 2) threads per device, each
    with a stream of its own (``DeviceSlot``), the slots taken in turn across the devices: one
    batch's host work (upload, tug rounds, judging) overlaps another's physics; ``drain`` waits
    for them all."""

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
        self.slot_turns = list(self.slots.queue)  # the streams take the slots in turn
        self.threads = ThreadPoolExecutor(self.slot_count)
        self.pending: list[Future[None]] = []
        self.busy: list[tuple[float, float]] = []  # (start, end) of each batch
        self.streams: dict[str, queue.Queue[Any]] = {}  # by task model: its lanes' job queue
        self.lock = threading.Lock()

    @property
    def device_s(self) -> float:
        """Wall time with at least one batch on the device."""
        return union_length(self.busy)

    def _scene(self, job: Any) -> Any:
        from harness.episode.scene_cache import get_scene

        return get_scene(job.task, self.scenes).scene

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
            batch = engine.batch(self._scene(job), job.task)
            items: list[Any] = [[(0, job)], None]
            LaneStream(batch, nlane=1, group=1).run(lambda block, items=items: items.pop(0))

    def to_stream(self, index: int, job: Any, lanes: int) -> None:
        """Hand a planned job to its task model's stream (started at its first job)."""
        key = batch_key(job)
        if key not in self.streams:
            self.streams[key] = self.stream(job, lanes)
        self.streams[key].put((index, job))

    def close_streams(self) -> None:
        """No more jobs: each stream drains and ends."""
        for jobs in self.streams.values():
            jobs.put(None)

    def stream(self, job: Any, lanes: int) -> queue.Queue[Any]:
        """Start a stream of ``lanes`` lanes for ``job``'s task model (on the next slot in
        turn): the queue to put (index, job) into, and ``None`` when planning is done."""
        from harness.engines.mjwarp.stream import LaneStream

        jobs: queue.Queue[Any] = queue.Queue()
        # a stream holds its slot for the whole run: the streams share the slots in turn (one
        # beyond the pool's threads starts when an earlier stream ends, after planning)
        engine, slot = self.slot_turns[len(self.streams) % len(self.slot_turns)]
        batch = engine.batch(self._scene(job), job.task, slot)
        stream = LaneStream(batch, nlane=lanes)
        waited = [0.0]
        closed = [False]

        def source(block: bool) -> list[Any] | None:
            """What was put since the last call; ``None`` once ``None`` was put."""
            if closed[0]:
                return None
            out: list[Any] = []
            clock = time.perf_counter()
            try:
                item = jobs.get(timeout=0.05) if block else jobs.get_nowait()
                while item is not None:
                    out.append(item)
                    item = jobs.get_nowait()
                closed[0] = True
                return out or None
            except queue.Empty:
                return out
            finally:
                if block:
                    waited[0] += time.perf_counter() - clock

        def run() -> None:
            clock = time.perf_counter()
            outcomes = stream.run(source)
            end = time.perf_counter()
            with self.lock:
                # device time: the stream's wall time less its waits for planned jobs
                self.busy.append((clock, end - waited[0]))
                self.outcomes.update({int(k): v for k, v in outcomes.items()})  # type: ignore[arg-type]
                self._add(stream.timings, lanes)

        self.pending.append(self.threads.submit(run))
        return jobs

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
        """Count a batch's (or a stream's) timings in; holding ``self.lock``."""
        for key in self.totals:
            self.totals[key] += getattr(timings, key)
        for key in ("world_steps", "motion_steps", "span_steps"):
            self.counts[key] += getattr(timings, key)
        self.counts["max_batch"] = max(self.counts["max_batch"], worlds)
        self.counts["batches"] += 1
        for key in ("peak_rows", "peak_contacts"):
            self.peaks[key] = max(self.peaks[key], float(getattr(timings, key)))
        self.peaks["memory_high_gb"] = sum(e.memory_high_gb() for e in self.engines)
