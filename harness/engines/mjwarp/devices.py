"""The device side of the GPU path: every device's lane streams, fed with jobs as they are planned.

``DeviceStreams`` is what ``harness sweep|tune --engine mjwarp`` (through the pool's
``harness.engines.mjwarp.service.DeviceService``) and the engines bench (``BENCH_LANES``) run:
jobs are queued per *stream key* (``stream_key``: one device model and one timing, so every
approach cone of a task model shares a stream); one thread per device runs one lane stream at a
time (``harness.engines.mjwarp.stream.LaneStream``), taking the key with the most jobs waiting;
each outcome is handed back as soon as it is judged. A stream ends when no more jobs will come,
or, while another key waits for the device, once it has nothing left to take or has held the
device for ``QUANTUM_S`` (its remaining jobs wait for its next turn). Several devices (every CUDA
device, or the comma-separated ``HARNESS_WARP_DEVICE``) each run a stream; two may serve one key.

The bench's lockstep batches (``BENCH_BATCH``...) are ``harness.benchmarks.engines_batches``.
"""

from __future__ import annotations

import math
import os
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Hashable
from dataclasses import dataclass, field
from typing import Any

from harness.engines.mjwarp.busy_time import union_length
from harness.engines.mjwarp.engine import CPU_DEVICE_NOTE
from harness.pick.outcome import PickOutcome

# How long a stream keeps the device while another key's jobs wait (s). Chosen, no public
# source: long against a stream's start (a graph capture, ~1 s), short against a sweep.
QUANTUM_S = 30.0
# Lanes per stream: CUDA devices step 8,192 worlds at 2.6-3.2 M world-steps/s on an H100
# (docs/engines.md, "Lanes"); Warp's CPU device is a test device (~60 world-steps/s on this
# project's 2-core machine), a few lanes. ``HARNESS_LANES`` overrides both.
CUDA_LANES = 8192
CPU_LANES = 4

# Called with (outcome, None) or (None, why the device could not run the job).
Answer = Callable[[PickOutcome | None, str | None], None]


StreamKey = tuple[Any, ...]


def stream_key(job: Any) -> StreamKey:
    """Jobs of one key share a lane stream: one device model (scene, arm, target, contact
    bits: the table verdict's replay is a model of its own) and one timing (the lanes take
    their window and servo chunks from the stream's first job)."""
    from harness.sim import scene_key

    task, schedule = job.task, job.schedule
    return (
        scene_key(task), task.arm, task.target_object.name, float(task.pick.hold_time),
        float(schedule.control_dt), tuple(schedule.chunk_sizes), int(schedule.warmup_steps),
        job.contact_key,
    )  # fmt: skip


# The fewest lanes a CUDA stream gets for a small run (a step of fewer worlds is no faster).
MIN_CUDA_LANES = 256
# Episodes per lane a run needs before more lanes pay: every lane steps whether busy or not,
# and a stream's first outcome comes one episode span (~9-12 s on an H100) after its start. On
# one H100, issue 34's 3,000-episode FR3 sweep took 46.8 s with 1,024 lanes, 50.7 s with 2,048
# and 76.6 s with 8,192 (docs/engines.md); chosen from those three runs.
EPISODES_PER_LANE = 3


def scene_for(task: Any, scenes: dict[Any, Any], lock: threading.Lock, contact: Any = None) -> Any:
    """``task``'s scene from ``scenes``, built once per ``scene_key`` (under ``lock``); with
    ``contact`` (a job's contact bits) other than its model's, a variant of it with those bits
    (``harness.engines.mjwarp.contact.scene_with_contact``), made once per bits."""
    import numpy as np

    from harness.engines.mjwarp.contact import contact_key, scene_with_contact
    from harness.sim import Scene, scene_key
    from harness.sim.masks import contact_bits

    key = scene_key(task)
    with lock:
        if key not in scenes:
            scenes[key] = Scene.for_task(task)
        scene = scenes[key]
        if contact is None or np.array_equal(contact, contact_bits(scene.model)):
            return scene
        variant = (key, contact_key(contact))
        if variant not in scenes:
            scenes[variant] = scene_with_contact(scene, contact)
        return scenes[variant]


def default_lanes(device: str, episodes: int | None = None) -> int:
    """``HARNESS_LANES``, else on the CPU ``CPU_LANES``, else on a CUDA device the power of
    two nearest above ``episodes / EPISODES_PER_LANE`` between ``MIN_CUDA_LANES`` and
    ``CUDA_LANES`` (``CUDA_LANES`` when the run's size is not known)."""
    chosen = os.environ.get("HARNESS_LANES")
    if chosen:
        return max(1, int(chosen))
    if device == "cpu":
        return CPU_LANES
    if episodes is None:
        return CUDA_LANES
    wanted = max(1, math.ceil(episodes / EPISODES_PER_LANE))
    return max(MIN_CUDA_LANES, min(CUDA_LANES, 1 << (wanted - 1).bit_length()))


@dataclass
class StreamStats:
    """What the devices did: jobs, lane streams run, the most lanes of one, seconds with a
    stream on a device (the union over devices), streams per device, the first-use compile
    (s) per (device, key), failures."""

    jobs: int = 0
    streams: int = 0
    lanes: int = 0
    device_s: float = 0.0
    by_device: dict[str, int] = field(default_factory=dict)
    compile_s: dict[str, float] = field(default_factory=dict)
    errors: list[str] = field(default_factory=list)
    timings: Any = None  # the streams' BatchTimings, summed (bench figures)

    # the names the sweep's summary line reads (it predates lane streams)
    @property
    def batches(self) -> int:
        return self.streams

    @property
    def largest(self) -> int:
        return self.lanes


def _log(message: str) -> None:
    print(f"mjwarp: {message}", file=sys.stderr, flush=True)


class DeviceStreams:
    """Lane streams on ``devices``, one at a time per device (see the module docstring)."""

    def __init__(
        self,
        devices: list[str],
        lanes: int | None = None,
        make_engine: Callable[[str], Any] | None = None,
        run_stream: Callable[..., None] | None = None,
        log: Callable[[str], None] = _log,
    ) -> None:
        """``lanes`` per stream (default ``default_lanes``); ``make_engine(device)`` the
        engine of a device (default ``MjwarpEngine``); ``run_stream(engine, scene, jobs_source,
        on_outcome, lanes)`` runs one stream instead of ``LaneStream`` (tests)."""
        self.devices = devices
        self.lanes = lanes
        self.episodes: int | None = None  # the run's size, when known (``default_lanes``)
        self.stats = StreamStats()
        self._make_engine = make_engine
        self._run_stream = run_stream or self._lane_stream
        self._log = log
        self._queues: dict[StreamKey, deque[tuple[Hashable, Any, Answer]]] = {}
        self._active: dict[StreamKey, int] = {}
        self._cond = threading.Condition()
        self._closed = False
        self._scenes: dict[Any, Any] = {}
        self._scene_lock = threading.Lock()
        self._spans: list[tuple[float, float]] = []
        self._seen: set[tuple[str, StreamKey]] = set()
        self._threads = [
            threading.Thread(target=self._serve, args=(d,), name=f"mjwarp-{d}", daemon=True)
            for d in devices
        ]
        if "cpu" in devices:
            log(CPU_DEVICE_NOTE)
        for thread in self._threads:
            thread.start()

    def submit(self, tag: Hashable, job: Any, answer: Answer) -> None:
        """Queue ``job`` for its key's stream; ``answer`` is called (from a device thread)."""
        try:
            key = stream_key(job)
        except Exception as exc:  # a job whose task cannot be read: its own error
            answer(None, f"{type(exc).__name__}: {exc}")
            return
        with self._cond:
            self._queues.setdefault(key, deque()).append((tag, job, answer))
            self._cond.notify_all()

    def close(self, wait_s: float | None = None) -> None:
        """No more jobs: the streams take what is queued, end, and their threads return
        (waited for up to ``wait_s``; None: until done)."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        for thread in self._threads:
            thread.join(timeout=wait_s)

    def abandon(self) -> None:
        """Drop every queued job unanswered (the run was interrupted) and close."""
        with self._cond:
            for jobs in self._queues.values():
                jobs.clear()
        self.close(wait_s=5.0)

    # ---- device threads

    def _pick(self) -> StreamKey | None:
        """(Holding the condition) the key to serve next, waiting for one; None once closed
        and nothing is queued. A key no other device serves first, the longest queue first."""
        while True:
            waiting = [k for k, jobs in self._queues.items() if jobs]
            if waiting:
                return max(
                    waiting, key=lambda k: (self._active.get(k, 0) == 0, len(self._queues[k]))
                )
            if self._closed:
                return None
            self._cond.wait(0.1)

    def _serve(self, device: str) -> None:
        engine: Any = None
        while True:
            with self._cond:
                key = self._pick()
                if key is None:
                    return
                self._active[key] = self._active.get(key, 0) + 1
            try:
                if engine is None:
                    engine = self._engine(device)
                self._one_stream(engine, device, key)
            except Exception as exc:  # the device could not even start: answer what waits
                self._fail(key, f"{type(exc).__name__}: {exc}")
            finally:
                with self._cond:
                    self._active[key] -= 1
                    self._cond.notify_all()

    def _engine(self, device: str) -> Any:
        if self._make_engine is not None:
            return self._make_engine(device)
        from harness.engines.mjwarp.engine import MjwarpEngine

        return MjwarpEngine(device)

    def _fail(self, key: StreamKey, message: str) -> None:
        with self._cond:
            jobs = list(self._queues.get(key, ()))
            self._queues.get(key, deque()).clear()
            self.stats.errors.append(message)
        for _, _, answer in jobs:
            answer(None, message)

    def _scene(self, job: Any) -> Any:
        """The job's scene, built as the workers build theirs (one per ``scene_key``), with the
        job's contact bits."""
        return scene_for(job.task, self._scenes, self._scene_lock, job.contact)

    def _variant(self, key: StreamKey) -> str:
        """A log label's note for a stream whose contact bits are not its task model's own
        (the table verdict's replay): ``" (contact bits <key>)"``, else ''."""
        with self._cond:
            jobs = self._queues.get(key)
            head = jobs[0][1] if jobs else None
        if head is None:
            return ""
        base = self._scene(head) is scene_for(head.task, self._scenes, self._scene_lock)
        return "" if base else f" (contact bits {key[-1]})"

    def _one_stream(self, engine: Any, device: str, key: StreamKey) -> None:
        """One stream of ``key``'s jobs on ``engine`` until it ends; every job it took is
        answered, with its outcome or the stream's error."""
        taken: dict[Hashable, Answer] = {}
        started = time.perf_counter()
        first = (device, key) not in self._seen
        self._seen.add((device, key))

        def source(block: bool) -> list[tuple[Hashable, Any]] | None:
            with self._cond:
                while True:
                    jobs = self._queues[key]
                    others = any(
                        k != key and q and self._active.get(k, 0) == 0
                        for k, q in self._queues.items()
                    )
                    turn_over = others and time.perf_counter() - started > QUANTUM_S
                    if jobs and not turn_over:
                        out = []
                        while jobs:
                            tag, job, answer = jobs.popleft()
                            taken[tag] = answer
                            out.append((tag, job))
                        return out
                    if self._closed or others:
                        return None
                    if not block:
                        return []
                    self._cond.wait(0.05)
                    block = False  # once: the caller asks again

        label = f"{device} {key[1]} {key[2]}{self._variant(key)}"

        def on_outcome(tag: Hashable, outcome: PickOutcome) -> None:
            answer = taken.pop(tag, None)
            if first and label not in self.stats.compile_s:
                spent = time.perf_counter() - started
                self.stats.compile_s[label] = spent
                self._log(f"{label}: first outcome after {spent:.1f} s (kernels ready)")
            with self._cond:
                self.stats.jobs += 1
            if answer is not None:
                answer(outcome, None)

        if first:
            self._log(
                f"{label}: first stream of this task model; Warp compiles its kernels unless "
                "they are in Warp's kernel cache (minutes on first use, seconds after)"
            )
        lanes = self.lanes or default_lanes(device, self.episodes)
        scene = None
        try:
            with self._cond:
                head = self._queues[key][0][1] if self._queues[key] else None
            if head is None:
                return
            scene = self._scene(head)
            self._run_stream(engine, scene, source, on_outcome, lanes)
        except Exception as exc:
            message = f"lane stream on {device} failed: {type(exc).__name__}: {exc}"
            with self._cond:
                self.stats.errors.append(message)
            for answer in taken.values():
                answer(None, message)
            taken.clear()
        finally:
            end = time.perf_counter()
            with self._cond:
                self._spans.append((started, end))
                self.stats.device_s = union_length(self._spans)
                self.stats.streams += 1
                self.stats.lanes = max(self.stats.lanes, lanes)
                self.stats.by_device[device] = self.stats.by_device.get(device, 0) + 1
        for answer in taken.values():  # a stream that ended without judging a job it took
            answer(None, "the lane stream ended without the job's outcome")

    def _lane_stream(
        self, engine: Any, scene: Any, source: Any, on_outcome: Any, lanes: int
    ) -> None:
        from harness.engines.mjwarp.stream import LaneStream

        # the task of the stream's first job: its device model (arm, target) and buffers
        head = source(True)
        while head == []:  # another device took what was queued: wait for more or the end
            head = source(True)
        if head is None:
            return
        batch = engine.batch(scene, head[0][1].task, contact=head[0][1].contact)
        stream = LaneStream(batch, nlane=lanes, on_outcome=on_outcome)
        given = [head]

        def replay_first(block: bool) -> Any:
            return given.pop() if given else source(block)

        stream.run(replay_first)
        with self._cond:
            if self.stats.timings is None:
                self.stats.timings = stream.timings
            elif self.stats.timings is not stream.timings:
                _add_timings(self.stats.timings, stream.timings)


def _add_timings(total: Any, more: Any) -> None:
    for name in (
        "physics_s", "tug_s", "upload_s", "download_s", "judge_s", "world_steps",
        "motion_steps", "span_steps", "tug_rounds", "tug_rungs", "reruns",
    ):  # fmt: skip
        setattr(total, name, getattr(total, name) + getattr(more, name))
    for name in ("peak_rows", "peak_contacts"):
        setattr(total, name, max(getattr(total, name), getattr(more, name)))
