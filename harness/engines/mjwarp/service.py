"""The devices shared by a process pool's workers, fed without blocking the planning.

With ``--engine mjwarp`` and the process backend (``harness.runs.device_pool``), each worker
runs several episodes at once, one thread each, of which only one plans at a time (the
worker's *baton*): at the execution, the episode's thread sends the chosen plan's job
(``DeviceJob``, with its control schedule) to the parent, hands the baton on and waits, so the
worker plans the next episode meanwhile (``PooledDeviceEngine``). The parent's ``DeviceService``
queues every job on the devices' lane streams (``harness.engines.mjwarp.devices.DeviceStreams``:
one stream per device at a time, jobs of a task model streamed through its lanes as they
arrive) and answers each job as soon as it is judged; the episode's thread takes the baton back
and builds its row exactly as the in-process engine would.

The wait is not the episode's: the episode's wall-clock budget is paused while it waits for the
device and for the baton (``harness.sim.budget.budget_paused``), and the parent does not count
it towards the worker's kill deadline. A device failure answers every job it held with an
error, which the worker stores as an ``error`` row naming it.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Hashable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from harness.errors import HarnessError

if TYPE_CHECKING:
    from harness.engines.base import Execution, ExecutionJob
    from harness.pick.outcome import PickOutcome

# How long an episode waits for its outcome before giving up with an error (covers MuJoCo
# Warp's first-use kernel compilation, ~4 min per task model on an H100 box, and a queue of
# other task models' streams; chosen, no public source).
DEVICE_WAIT_LIMIT_S = 3600.0


@dataclass
class DeviceRequest:
    """Worker to parent: execute this job on the shared devices (``track``: the worker's
    episode thread that waits for it)."""

    track: int
    job: Any  # harness.engines.mjwarp.schedule.DeviceJob


@dataclass
class DeviceReply:
    """Parent to worker: the job's outcome, or why the device could not run it."""

    track: int
    outcome: PickOutcome | None
    error: str | None = None


class Baton:
    """One episode thread of a worker plans at a time: the one holding the baton.

    ``hold(track)`` takes it (telling ``on_hold`` which track holds it, so the parent knows
    which episode a hung worker was running); ``wait_for(track)`` gives it away while the
    track's job is on the device and returns the reply once it came and the baton is back.
    """

    def __init__(self, on_hold: Callable[[int | None], None]) -> None:
        self._lock = threading.Lock()
        self._on_hold = on_hold
        self._replies: dict[int, DeviceReply] = {}
        self._arrived: dict[int, threading.Event] = {}
        self._local = threading.local()

    @property
    def track(self) -> int:
        """The track of the calling episode thread."""
        return int(self._local.track)

    def hold(self, track: int) -> None:
        self._lock.acquire()
        self._local.track = track
        self._on_hold(track)

    def release(self) -> None:
        self._lock.release()

    def expect(self, track: int) -> None:
        """Before sending a request: its reply is awaited (a reply may come before the wait)."""
        self._arrived[track] = threading.Event()

    def deliver(self, reply: DeviceReply) -> None:
        """(The worker's receiving thread) the reply of a track's job."""
        self._replies[reply.track] = reply
        event = self._arrived.get(reply.track)
        if event is not None:
            event.set()

    def wait_for(self, track: int, limit_s: float) -> DeviceReply | None:
        """Give the baton away until ``track``'s reply came (None after ``limit_s``), then
        take it back."""
        event = self._arrived[track]
        self.release()
        try:
            arrived = event.wait(limit_s)
        finally:
            self.hold(track)
        self._arrived.pop(track, None)
        return self._replies.pop(track, None) if arrived else None

    def wait_elsewhere(self, event: threading.Event) -> None:
        """(Holding the baton) give it away until ``event`` is set, then take it back: the
        wait of an episode for an outcome another episode of its seed is executing
        (``harness.episode.outcome_wait``). The budget is paused and the parent told that no
        thread of this worker plans for it (``on_hold(None)``), so neither counts the wait."""
        from harness.sim.budget import budget_paused

        track = self.track
        with budget_paused():
            self._on_hold(None)
            self.release()
            try:
                event.wait()
            finally:
                self.hold(track)


class PooledDeviceEngine:
    """A worker's ``mjwarp`` engine: makes the job's schedule here, sends it to the parent's
    devices and, while it waits, lets the worker's other episodes plan."""

    name = "mjwarp"

    def __init__(self, send: Callable[[Any], None], baton: Baton) -> None:
        self.send = send
        self.baton = baton

    def execute(self, job: ExecutionJob) -> Execution:
        from harness.engines.base import Execution
        from harness.engines.mjwarp.schedule import device_job
        from harness.pick.validity import validity_enabled
        from harness.sim.budget import budget_paused

        packed = device_job(job)
        track = self.baton.track
        self.baton.expect(track)
        self.send(DeviceRequest(track, packed))
        with budget_paused():
            reply = self.baton.wait_for(track, DEVICE_WAIT_LIMIT_S)
        if reply is None:
            raise HarnessError(
                f"the shared mjwarp device gave no outcome within {DEVICE_WAIT_LIMIT_S:g} s"
            )
        if reply.error is not None or reply.outcome is None:
            raise HarnessError(f"mjwarp device: {reply.error}")
        return Execution.of_batch(reply.outcome, validity_enabled(job.task.pick))


class DeviceService:
    """The parent's side: every job a worker sends goes to the devices' lane streams; its
    answer goes back to the worker as soon as it is judged."""

    def __init__(self, devices: list[str] | None = None, **streams: Any) -> None:
        """``devices``: default ``default_devices`` (every CUDA device, or
        ``HARNESS_WARP_DEVICE``); ``streams``: more ``DeviceStreams`` arguments (tests)."""
        from harness.engines.mjwarp.devices import DeviceStreams

        if devices is None:
            from harness.engines.mjwarp.engine import default_devices

            devices = default_devices()
        self.devices = devices
        self.streams = DeviceStreams(devices, **streams)
        self.stats = self.streams.stats

    def submit(
        self, tag: Hashable, job: Any, answer: Callable[[DeviceReply], None], track: int = 0
    ) -> None:
        """Queue ``job``; ``answer`` gets its ``DeviceReply`` (from a device thread)."""

        def reply(outcome: PickOutcome | None, error: str | None) -> None:
            answer(DeviceReply(track, outcome, error))

        self.streams.submit(tag, job, reply)

    def stop(self, interrupted: bool = False) -> None:
        """No more jobs: the streams finish what they hold (interrupted: drop what waits)."""
        if interrupted:
            self.streams.abandon()
        else:
            self.streams.close()
