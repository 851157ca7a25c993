"""The devices shared by a process pool's workers: their execution jobs stepped in batches.

With ``--engine mjwarp`` and the process backend, each worker plans its episodes as always and,
at the execution, sends the chosen plan's job (``DeviceJob``, with its control schedule) to the
parent over its pipe and waits (``PooledDeviceEngine``, the worker's ``mjwarp`` engine). A thread
of the parent (``DeviceService``) owns the one MuJoCo Warp engine: it gathers the jobs waiting
(at most one per worker), steps the jobs of each task model as one batch of worlds, and answers
each worker with its outcome, which the worker turns into its row as the in-process engine
would. So a pool of W workers shares one CUDA context per device and one set of compiled
kernels, and batches hold up to W worlds (more workers than cores keep both the cores and the
device busy). With several GPUs (``default_devices``) the service runs one engine on each and
hands each batch to the first free slot, the slots taken in turn across the devices.

The wait is not the episode's: the worker's wall-clock budget is paused while it waits
(``harness.sim.budget.budget_paused``), and the parent does not count it towards the worker's
kill deadline. A device failure answers every job of its batch with an error, which the worker
stores as an ``error`` row naming it.
"""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from multiprocessing.connection import Connection
from typing import TYPE_CHECKING, Any

from harness.engines.mjwarp.busy_time import union_length
from harness.errors import HarnessError

if TYPE_CHECKING:
    from harness.engines.base import Execution, ExecutionJob
    from harness.pick.outcome import PickOutcome

# How long a worker waits for its outcome before giving up with an error (covers MuJoCo Warp's
# first-use kernel compilation, ~4 min for the first task model on an H100 box; chosen, no
# public source).
DEVICE_WAIT_LIMIT_S = 1800.0
# After the first job of a batch arrives, how long the service waits for the other busy
# workers' jobs before it steps what it has; it stops waiting as soon as every busy worker has
# sent one. Chosen, no public source: several planning times of a typical episode (~50 ms),
# short against one batch on the device (~0.5 s for a pick at pace 0.3).
GATHER_S = 0.5


# Batches on the device at once, each on a stream of its own (``harness.engines.mjwarp.slot``):
# while one steps, the next gathers the jobs of the workers it answered. Chosen, no public
# source (two hides one batch's host work behind the other's physics).
SLOTS = 2


@dataclass
class DeviceRequest:
    """Worker to parent: execute this job on the shared device."""

    job: Any  # harness.engines.mjwarp.schedule.DeviceJob


@dataclass
class DeviceReply:
    """Parent to worker: the job's outcome, or why the device could not run it."""

    outcome: PickOutcome | None
    error: str | None = None


@dataclass
class DeviceStats:
    """What the service did: batches, jobs, the largest batch, seconds with a batch on a
    device (the union of the batches' spans: several may overlap), batches per device."""

    batches: int = 0
    jobs: int = 0
    largest: int = 0
    device_s: float = 0.0
    errors: list[str] = field(default_factory=list)
    by_device: dict[str, int] = field(default_factory=dict)  # batches run on each device


class PooledDeviceEngine:
    """A worker's ``mjwarp`` engine: makes the job's schedule here, runs it on the parent's
    device (``DeviceService``) and waits for the outcome."""

    name = "mjwarp"

    def __init__(self, conn: Connection) -> None:
        self.conn = conn

    def execute(self, job: ExecutionJob) -> Execution:
        from harness.engines.mjwarp.schedule import device_job
        from harness.pick.validity import validity_enabled
        from harness.sim.budget import budget_paused

        packed = device_job(job)
        self.conn.send(DeviceRequest(packed))
        with budget_paused():
            if not self.conn.poll(DEVICE_WAIT_LIMIT_S):
                raise HarnessError(
                    f"the shared mjwarp device gave no outcome within {DEVICE_WAIT_LIMIT_S:g} s"
                )
            reply = self.conn.recv()
        if not isinstance(reply, DeviceReply):
            raise HarnessError(f"the parent answered a device request with {type(reply).__name__}")
        if reply.error is not None or reply.outcome is None:
            raise HarnessError(f"mjwarp device: {reply.error}")
        from harness.engines.base import Execution

        return Execution.of_batch(reply.outcome, validity_enabled(job.task.pick))


Answer = Callable[[DeviceReply], None]


class DeviceService:
    """The parent's device thread: gathers waiting jobs, steps them in batches, answers."""

    def __init__(
        self,
        waiting: Callable[[], int],
        devices: list[str] | None = None,
        execute: Callable[[Any, list[Any]], list[PickOutcome]] | None = None,
    ) -> None:
        """``waiting``: how many workers may still send a job before the current ones are
        answered (the batch stops gathering once that many arrived); ``devices``: one
        ``mjwarp`` engine on each, ``SLOTS`` batches each (default: ``default_devices``, every
        CUDA device); ``execute(scene, jobs)`` runs one batch instead (tests)."""
        self.waiting = waiting
        if devices is None:
            from harness.engines.mjwarp.engine import default_devices

            devices = default_devices() if execute is None else ["stub"]
        self.devices = devices
        self._execute_batch = execute
        self.stats = DeviceStats()
        self._queue: queue.Queue[tuple[Any, Answer] | None] = queue.Queue()
        self._engines: list[Any] = []
        self._scenes: dict[Any, Any] = {}
        self._lock = threading.Lock()  # the stats, the count of jobs in flight
        self._in_flight = 0  # jobs handed to a slot and not yet answered
        slots = SLOTS * len(devices)
        self._free = threading.Semaphore(slots)
        self._slots: queue.Queue[tuple[Any, Any]] = queue.Queue()  # (engine, slot), free ones
        self._spans: list[tuple[float, float]] = []
        self._pool = ThreadPoolExecutor(slots, thread_name_prefix="mjwarp-slot")
        self._thread = threading.Thread(target=self._loop, name="mjwarp-device", daemon=True)
        self._thread.start()

    def submit(self, job: Any, answer: Answer) -> None:
        """Queue ``job``; ``answer`` is called (from the device thread) with its reply."""
        self._queue.put((job, answer))

    def stop(self) -> None:
        self._queue.put(None)
        self._thread.join(timeout=60)

    def _gather(self, first: tuple[Any, Answer]) -> list[tuple[Any, Answer]]:
        """The first job and those that arrive within ``GATHER_S`` while more may come (a
        stop request stays queued for the loop)."""
        batch = [first]
        deadline = time.monotonic() + GATHER_S
        while True:
            try:
                item = self._queue.get_nowait()
            except queue.Empty:
                with self._lock:
                    may_send = self.waiting() - self._in_flight  # those in flight wait
                if len(batch) >= max(1, may_send) or time.monotonic() >= deadline:
                    return batch
                time.sleep(0.002)
                continue
            if item is None:
                self._queue.put(None)
                return batch
            batch.append(item)

    def _loop(self) -> None:
        """Gather a batch as soon as a slot is free and hand it to the slot's thread."""
        while True:
            first = self._queue.get()
            if first is None:
                self._pool.shutdown(wait=True)
                return
            self._free.acquire()
            batch = self._gather(first)
            groups = self._groups(batch)
            with self._lock:
                self._in_flight += len(batch)
            self._pool.submit(self._run, groups, len(batch))

    def _groups(self, batch: list[tuple[Any, Answer]]) -> list[list[tuple[Any, Answer]]]:
        """The jobs by batch key (scenes are built here, in one thread); a job whose scene
        cannot be built is answered with its error."""
        groups: dict[tuple[Any, ...], list[tuple[Any, Answer]]] = {}
        for item in batch:
            try:
                key = self._key(item[0])
            except Exception as exc:  # a scene that cannot be built: that job's error
                item[1](DeviceReply(None, f"{type(exc).__name__}: {exc}"))
                continue
            groups.setdefault(key, []).append(item)
        return list(groups.values())

    def _run(self, groups: list[list[tuple[Any, Answer]]], count: int) -> None:
        """(A slot's thread) each group as one batch of worlds; every job answered, error or
        not; the slot is free again afterwards."""
        clock = time.perf_counter()
        try:
            for items in groups:
                self._run_group(items)
        finally:
            with self._lock:
                self._in_flight -= count
                self._spans.append((clock, time.perf_counter()))
                self.stats.device_s = union_length(self._spans)
            self._free.release()

    def _run_group(self, items: list[tuple[Any, Answer]]) -> None:
        jobs = [job for job, _ in items]
        try:
            outcomes = self._execute(jobs)
        except Exception as exc:
            message = f"batch of {len(jobs)} failed: {type(exc).__name__}: {exc}"
            with self._lock:
                self.stats.errors.append(message)
            for _, answer in items:
                answer(DeviceReply(None, message))
            return
        for (_, answer), outcome in zip(items, outcomes, strict=True):
            answer(DeviceReply(outcome))
        with self._lock:
            self.stats.batches += 1
            self.stats.jobs += len(jobs)
            self.stats.largest = max(self.stats.largest, len(jobs))

    def _scene(self, task: Any) -> Any:
        """The task's scene, built as the workers build theirs (one per ``scene_key``)."""
        from harness.sim import Scene, scene_key

        key = scene_key(task)
        if key not in self._scenes:
            self._scenes[key] = Scene.for_task(task)
        return self._scenes[key]

    def _key(self, job: Any) -> tuple[Any, ...]:
        """Jobs of one key run as one batch: one device model (task model, arm, target) and
        the same timing (``WorldBatch.run`` takes these from its first job)."""
        scene = self._scene(job.task)
        schedule = job.schedule
        return (
            id(scene.model), job.task.arm, job.task.target_object.name,
            float(job.task.pick.hold_time), float(schedule.control_dt),
            tuple(schedule.chunk_sizes), int(schedule.warmup_steps),
        )  # fmt: skip

    def _execute(self, jobs: list[Any]) -> list[PickOutcome]:
        scene = self._scene(jobs[0].task)
        if self._execute_batch is not None:
            return self._execute_batch(scene, jobs)
        with self._lock:
            if not self._engines:
                self._start_engines()
        engine, slot = self._slots.get()
        try:
            outcomes, _ = engine.execute_many(scene, jobs, slot)
        finally:
            self._slots.put((engine, slot))
        with self._lock:
            self.stats.by_device[engine.device] = self.stats.by_device.get(engine.device, 0) + 1
        return outcomes

    def _start_engines(self) -> None:
        """One engine per device and its slots, queued alternately across the devices so that
        consecutive batches go to different devices."""
        from harness.engines.mjwarp.engine import MjwarpEngine

        self._engines = [MjwarpEngine(device) for device in self.devices]
        slots = [engine.slots(SLOTS) for engine in self._engines]
        for k in range(SLOTS):
            for engine, own in zip(self._engines, slots, strict=True):
                self._slots.put((engine, own[k]))
