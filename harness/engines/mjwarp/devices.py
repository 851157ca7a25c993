"""The device side of the GPU path: every device's lane streams, fed with jobs as they are planned.

``DeviceStreams`` is what ``harness sweep|tune --engine mjwarp`` (through the pool's
``harness.engines.mjwarp.service.DeviceService``) and the engines bench (``BENCH_LANES``) run:
jobs are queued per *stream key* (``stream_key``: one device model and one timing, so every
approach cone of a task model shares a stream); each device runs up to ``streams_per_device``
lane streams at once (``harness.engines.mjwarp.stream.LaneStream``), one per key, each on a CUDA
stream of its own (``harness.engines.mjwarp.slot``: one host lock for every Warp call, released
while a stream's replay runs, so the other streams issue theirs). A small lane count is
latency-bound (an episode's span, ~3,600 physics steps, takes ~9-12 s on a stream whatever its
lanes), so the task models of a sweep stepping side by side cost about one span each instead of
one after another. A new stream takes the waiting key no device serves yet, the longest queue
first; its lanes are sized to the key's jobs (``lanes_for``), within the device's lane budget
(``device_lanes``). Each outcome is handed back as soon as it is judged. A stream ends when no
more jobs will come, or, while a key waits that no device can start (every stream slot taken or
the lane budget spent), once it has nothing left to take or has held its slot for ``QUANTUM_S``
(its remaining jobs wait for its next turn). Several devices (every CUDA device, or the
comma-separated ``HARNESS_WARP_DEVICE``) each run their own streams; two may serve one key,
each taking its even share of what waits. Bench batches: ``harness.benchmarks.engines_batches``.
"""

from __future__ import annotations

import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Hashable, Iterable
from typing import Any

from harness.engines.mjwarp import switch
from harness.engines.mjwarp.busy_time import union_length
from harness.engines.mjwarp.engine import CPU_DEVICE_NOTE
from harness.engines.mjwarp.lane_sizes import (
    CPU_LANES,
    CUDA_DEVICE_LANES,
    MIN_CUDA_LANES,
    default_lanes,
    env_int,
    even_share,
    is_cuda,
    streams_per_device,
)
from harness.engines.mjwarp.stream_keys import (
    StreamKey,
    scene_for,
    stream_key,
    stream_label,
    task_key,
)
from harness.engines.mjwarp.stream_stats import StreamStats, add_timings
from harness.pick.outcome import PickOutcome

# How long a stream keeps its slot while another key's jobs wait for one (s). Chosen, no public
# source: long against a stream's start (a graph capture, ~1 s), short against a sweep.
QUANTUM_S = 30.0
# The stream key's first entries: the task model (``task_key``).
TASK_KEY_LENGTH = 4

# The engines (their device models) and scenes of the real devices outlive one run: a tune's
# race runs a pool, and so a ``DeviceStreams``, per round, and would otherwise build every task
# model's scene and device model again each round.
_ENGINES: dict[str, Any] = {}
_ENGINE_LOCK = threading.Lock()
_SCENES: dict[Any, Any] = {}
_SCENE_LOCK = threading.Lock()

# Called with (outcome, None) or (None, why the device could not run the job).
Answer = Callable[[PickOutcome | None, str | None], None]


# When this process's device side was loaded: the device lines carry the seconds since, so a
# sitting's log shows where the gaps between streams, phases and first outcomes lie.
_LOADED = time.perf_counter()


def _log(message: str) -> None:
    print(f"mjwarp {time.perf_counter() - _LOADED:6.1f} s: {message}", file=sys.stderr, flush=True)


class DeviceStreams:
    """Lane streams on ``devices``, several at once per device (see the module docstring)."""

    def __init__(
        self,
        devices: list[str],
        lanes: int | None = None,
        make_engine: Callable[[str], Any] | None = None,
        run_stream: Callable[..., None] | None = None,
        log: Callable[[str], None] = _log,
        per_device: int | None = None,
    ) -> None:
        """``lanes`` per stream (default ``lanes_for``); ``make_engine(device)`` the engine of
        a device (default ``MjwarpEngine``); ``run_stream(engine, scene, jobs_source,
        on_outcome, lanes)`` runs one stream instead of ``LaneStream`` (tests); ``per_device``:
        streams at once per device (default ``streams_per_device``)."""
        self.devices = devices
        self.lanes = lanes
        self.episodes: int | None = None  # the run's size, when known (``default_lanes``)
        self.expected: dict[tuple[Any, ...], int] = {}  # jobs per task key (``expect``)
        self.stats = StreamStats()
        self.per_device = {d: per_device or streams_per_device(d) for d in devices}
        self._make_engine = make_engine
        self._run_stream = run_stream or self._lane_stream
        self._log = log
        self._queues: dict[StreamKey, deque[tuple[Hashable, Any, Answer]]] = {}
        self._on: dict[str, dict[StreamKey, int]] = {d: {} for d in devices}  # key: lanes
        self._idle: dict[str, int] = {d: 0 for d in devices}  # threads waiting for a key
        self._taken: dict[tuple[Any, ...], int] = {}  # jobs streams took, per task key
        self._held: dict[tuple[str, StreamKey], dict[Hashable, Any]] = {}  # a stream's unanswered
        self._cond = threading.Condition()
        self._closed = False
        shared = make_engine is None  # the real engines: kept for the process's next run
        self._engines: dict[str, Any] = _ENGINES if shared else {}
        self._engine_lock = _ENGINE_LOCK if shared else threading.Lock()
        self._local = threading.local()  # a thread's device slot (its CUDA stream)
        self._scenes: dict[Any, Any] = _SCENES if shared else {}
        self._scene_lock = _SCENE_LOCK if shared else threading.Lock()
        self._spans: list[tuple[float, float]] = []
        self._seen: set[tuple[str, StreamKey]] = set()
        self._examples: dict[tuple[Any, ...], Any] = {}  # a task per expected key (``prepare``)
        self._prewarm: threading.Thread | None = None
        self._threads = [
            threading.Thread(target=self._serve, args=(d,), name=f"mjwarp-{d}-{k}", daemon=True)
            for d in devices
            for k in range(self.per_device[d])
        ]
        if "cpu" in devices:
            log(CPU_DEVICE_NOTE)
        self._switch = switch.shorten()  # put back by ``close``
        for thread in self._threads:
            thread.start()

    def expect(self, tasks: Iterable[Any]) -> None:
        """The run's jobs will be of these tasks (one per episode): a stream's lanes are sized
        to the jobs its key still expects (``lanes_for``)."""
        counts: dict[tuple[Any, ...], int] = {}
        # a sweep point's episodes share its task object (held here, so no id is reused)
        known: dict[int, tuple[Any, tuple[Any, ...]]] = {}
        for task in tasks:
            if id(task) not in known:
                known[id(task)] = (task, task_key(task))
            key = known[id(task)][1]
            counts[key] = counts.get(key, 0) + 1
        with self._cond:
            self.expected = counts
            self._examples = {key: task for task, key in known.values()}

    def prepare(self) -> None:
        """Load each expected task model on every device in the background (``prewarm``), so
        the first streams do not wait for it; nothing with stand-in engines or streams."""
        if self._make_engine is not None or self._run_stream != self._lane_stream:
            return
        from harness.engines.mjwarp.prewarm import prewarm, warm_model

        def warm(device: str, task: Any) -> None:
            scene = scene_for(task, self._scenes, self._scene_lock)
            warm_model(self._engine(device), scene, task)

        with self._cond:
            tasks = list(self._examples.values())
        self._prewarm = prewarm(
            [(device, task) for device in self.devices for task in tasks], warm, self._log
        )

    def planned_lanes(self) -> int:
        """The lanes every device's streams will hold at once when each expected task model has
        a stream (what the planning pool keeps fed)."""
        total = 0
        for device in self.devices:
            if self.lanes or env_int("HARNESS_LANES") or not self.expected:
                each = [self.lanes or default_lanes(device, self.episodes)] * len(
                    self.expected or [0]
                )
            else:
                cap = self._even_share(device)
                each = sorted(
                    (min(cap, default_lanes(device, n)) for n in self.expected.values()),
                    reverse=True,
                )
            total += min(self._budget(device), sum(each[: self.per_device[device]]))
        return total

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
        switch.restore(self._switch)
        self._switch = None

    def abandon(self) -> None:
        """Drop every queued job unanswered (the run was interrupted) and close."""
        with self._cond:
            for jobs in self._queues.values():
                jobs.clear()
        self.close(wait_s=5.0)

    # ---- lanes

    def _fixed_lanes(self) -> int | None:
        return self.lanes or env_int("HARNESS_LANES")

    def _budget(self, device: str) -> int:
        """The lanes of all the device's streams together."""
        fixed = self._fixed_lanes()
        if fixed:
            return fixed * self.per_device[device]
        if not is_cuda(device):
            return CPU_LANES * self.per_device[device]
        return env_int("HARNESS_DEVICE_LANES") or CUDA_DEVICE_LANES

    def _floor(self, device: str) -> int:
        """The fewest lanes a stream of the device starts with."""
        fixed = self._fixed_lanes()
        if fixed:
            return fixed
        return MIN_CUDA_LANES if is_cuda(device) else CPU_LANES

    def lanes_for(self, device: str, key: StreamKey) -> int:
        """(Holding the condition) a new stream's lanes: fixed (``lanes``, ``HARNESS_LANES``),
        else ``default_lanes`` of the jobs its key still has: those waiting, or those its task
        model is expected to send (``expect``) less those already taken, whichever is more
        (the run's episodes when nothing is expected)."""
        fixed = self._fixed_lanes()
        if fixed:
            return fixed
        if not self.expected:
            return default_lanes(device, self.episodes)
        tkey = key[:TASK_KEY_LENGTH]
        left = self.expected.get(tkey, 0) - self._taken.get(tkey, 0)
        wanted = default_lanes(device, max(len(self._queues.get(key, ())), left))
        return min(wanted, self._even_share(device))

    def _even_share(self, device: str) -> int:
        """(Holding the condition) the most lanes a stream of ``device`` takes: its budget
        filled evenly over the lanes the task models with jobs still to come want (the largest
        that it runs at once)."""
        left = [n - self._taken.get(k, 0) for k, n in self.expected.items()]
        wants = sorted((default_lanes(device, n) for n in left if n > 0), reverse=True)
        return even_share(
            self._budget(device), wants[: self.per_device[device]], self._floor(device)
        )

    # ---- device threads

    def _serving(self, key: StreamKey) -> int:
        return sum(key in on for on in self._on.values())

    def _share(self, device: str, key: StreamKey, waiting: int, want: int | None) -> int | None:
        """(Holding the condition) the most of ``waiting`` jobs ``device``'s stream of ``key``
        takes: its room ``want``, and where several devices serve the key, what evens out the
        jobs they hold (without it, on two H200s one stream took 10,240 of 11,084 jobs and the
        other held at most 844)."""
        mates = [held for (_, k), held in self._held.items() if k == key]
        if len(mates) < 2:
            return want
        total = waiting + sum(len(held) for held in mates)
        even = max(0, -(-total // len(mates)) - len(self._held[(device, key)]))
        return even if want is None else min(want, even)

    def _can_start(self, device: str) -> bool:
        """(Holding the condition) an idle thread of ``device`` could start a stream now."""
        left = self._budget(device) - sum(self._on[device].values())
        return self._idle[device] > 0 and left >= self._floor(device)

    def _starved(self, key: StreamKey) -> bool:
        """(Holding the condition) another key's jobs wait, no device serves it, and no
        device can start a stream for it: streams should make way."""
        waiting = any(k != key and q and self._serving(k) == 0 for k, q in self._queues.items())
        return waiting and not any(self._can_start(d) for d in self.devices)

    def _pick(self, device: str) -> tuple[StreamKey, int] | None:
        """(Holding the condition) the key this thread of ``device`` serves next and its lanes,
        waiting for one; None once closed and nothing is queued that it could take. A key no
        device serves first, then the longest queue; never a key this device already serves."""
        while True:
            on = self._on[device]
            waiting = [k for k, jobs in self._queues.items() if jobs and k not in on]
            left = self._budget(device) - sum(on.values())
            if waiting and left >= self._floor(device):
                key = max(waiting, key=lambda k: (self._serving(k) == 0, len(self._queues[k])))
                lanes = max(self._floor(device), min(self.lanes_for(device, key), left))
                on[key] = lanes
                self.stats.concurrent = max(self.stats.concurrent, len(on))
                return key, lanes
            if self._closed and not waiting:
                return None
            self._idle[device] += 1
            try:
                self._cond.wait(0.1)
            finally:
                self._idle[device] -= 1

    def _serve(self, device: str) -> None:
        while True:
            with self._cond:
                picked = self._pick(device)
                if picked is None:
                    return
                key, lanes = picked
            try:
                engine = self._engine(device)
                self._one_stream(engine, device, key, lanes)
            except Exception as exc:  # the device could not even start: answer what waits
                self._fail(key, f"{type(exc).__name__}: {exc}")
            finally:
                with self._cond:
                    self._on[device].pop(key, None)
                    self._cond.notify_all()

    def _engine(self, device: str) -> Any:
        """The device's engine, one per device, shared by its streams."""
        with self._engine_lock:
            if device not in self._engines:
                if self._make_engine is not None:
                    self._engines[device] = self._make_engine(device)
                else:
                    from harness.engines.mjwarp.engine import MjwarpEngine

                    self._engines[device] = MjwarpEngine(device)
            return self._engines[device]

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

    def _one_stream(self, engine: Any, device: str, key: StreamKey, lanes: int) -> None:
        """One stream of ``key``'s jobs on ``engine`` until it ends; every job it took is
        answered, with its outcome or the stream's error."""
        taken: dict[Hashable, Answer] = {}
        started = time.perf_counter()
        tkey = key[:TASK_KEY_LENGTH]
        with self._cond:
            first = (device, key) not in self._seen
            self._seen.add((device, key))
            self._held[(device, key)] = taken

        def source(block: bool, want: int | None = None) -> list[tuple[Hashable, Any]] | None:
            with self._cond:
                while True:
                    jobs = self._queues[key]
                    starved = self._starved(key)
                    turn_over = starved and time.perf_counter() - started > QUANTUM_S
                    if jobs and not turn_over:
                        out = []
                        if not block:  # an idle stream takes what it has room for
                            want = self._share(device, key, len(jobs), want)
                        while jobs and (want is None or len(out) < want):
                            tag, job, answer = jobs.popleft()
                            taken[tag] = answer
                            out.append((tag, job))
                        self._taken[tkey] = self._taken.get(tkey, 0) + len(out)
                        return out
                    if self._closed or starved:
                        return None
                    if not block:
                        return []
                    self._cond.wait(0.05)
                    block = False  # once: the caller asks again

        label = f"{device} {stream_label(key)}{self._variant(key)}"

        def on_outcome(tag: Hashable, outcome: PickOutcome) -> None:
            answer = taken.pop(tag, None)
            with self._cond:
                self.stats.jobs += 1
                self.stats.jobs_by_device[device] = self.stats.jobs_by_device.get(device, 0) + 1
                said = label in self.stats.compile_s
                if first and not said:
                    self.stats.compile_s[label] = time.perf_counter() - started
            if first and not said:
                spent = self.stats.compile_s[label]
                self._log(f"{label}: first outcome after {spent:.1f} s (kernels ready)")
            if answer is not None:
                answer(outcome, None)

        if first:
            self._log(
                f"{label}: first stream of this task model ({lanes} lanes); Warp compiles its "
                "kernels unless they are in Warp's kernel cache (minutes on first use, seconds "
                "after)"
            )
        try:
            with self._cond:
                head = self._queues[key][0][1] if self._queues[key] else None
            if head is None:
                return
            scene = self._scene(head)
            self._run_stream(engine, scene, source, on_outcome, lanes)
        except Exception as exc:
            message = f"lane stream of {label} failed: {type(exc).__name__}: {exc}"
            with self._cond:
                self.stats.errors.append(message)
            for answer in list(taken.values()):
                answer(None, message)
            taken.clear()
        finally:
            self._stream_ended(device, key, started, lanes)
        for answer in taken.values():  # a stream that ended without judging a job it took
            answer(None, f"the lane stream of {label} ended without the job's outcome")

    def _stream_ended(self, device: str, key: StreamKey, started: float, lanes: int) -> None:
        """Count a stream that ended: its span of device time, its lanes, its device."""
        end = time.perf_counter()
        with self._cond:
            self._held.pop((device, key), None)
            self._spans.append((started, end))
            self.stats.device_s = union_length(self._spans)
            self.stats.streams += 1
            self.stats.lanes = max(self.stats.lanes, lanes)
            self.stats.by_device[device] = self.stats.by_device.get(device, 0) + 1

    def _slot(self, engine: Any) -> Any:
        """This thread's device slot: a CUDA stream of its own on the engine's device, made
        once per thread (under the host lock: Warp's current device is process-wide)."""
        slot = getattr(self._local, "slot", None)
        if slot is None:
            from harness.engines.mjwarp.slot import HOST_LOCK

            with HOST_LOCK:
                slot = self._local.slot = engine.slots(1)[0]
        return slot

    def _lane_stream(
        self, engine: Any, scene: Any, source: Any, on_outcome: Any, lanes: int
    ) -> None:
        from harness.engines.mjwarp.stream import TUG_GROUP, LaneStream

        # the task of the stream's first job: its device model (target) and buffers
        head = source(True, lanes)
        while head == []:  # another device took what was queued: wait for more or the end
            head = source(True, lanes)
        if head is None:
            return
        batch = engine.batch(scene, head[0][1].task, self._slot(engine), contact=head[0][1].contact)
        # a tug group flushes once it holds as many jobs as the lanes step, so a group of more
        # than twice the lanes never fills; fewer job slots, less memory per stream
        group = min(TUG_GROUP, 2 * lanes)
        stream = LaneStream(batch, nlane=lanes, group=group, on_outcome=on_outcome)
        given = [head]

        def replay_first(block: bool, want: int) -> Any:
            return given.pop() if given else source(block, want)

        stream.run(replay_first)
        task = head[0][1].task
        label = f"{engine.device} {task.robot} {task.target_object.name}"  # (both arms)
        self._log(f"{label} stream: {stream.summary()}")
        with self._cond:
            if self.stats.timings is None:
                self.stats.timings = stream.timings
            elif self.stats.timings is not stream.timings:
                add_timings(self.stats.timings, stream.timings)
