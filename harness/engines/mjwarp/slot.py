"""Several batches of worlds in flight on one device, each on its own CUDA stream.

One batch alone leaves the GPU idle while the host uploads it, decides its tug rounds and judges
it, and leaves the host idle while the GPU steps it. With two slots, one thread per slot, one
batch's host work overlaps another's physics, and two batches' kernels can run side by side.

Warp keeps one *current* device, and one current stream per device, for the whole process (not
per thread), so every slot of every device shares one lock (``HOST_LOCK``): a slot's thread holds
it while it issues Warp calls (with its own device and stream made current each time it takes
the lock) and lets go of it while a graph launch blocks (``launch``) and while it waits for its
stream (``wait``): on a blocking-sync CUDA event, asleep in the driver, rather than spinning a
core in a CUDA synchronize (the driver's default with fewer contexts than cores), a core the
planning processes beside this one can use. On Warp's CPU device there are
no streams: the slots take turns.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from types import TracebackType
from typing import Any

import warp as wp

POLL_S = 0.0005
# One lock for the host side of every slot: two threads issuing Warp calls for two devices at
# once raced on Warp's process-wide current device (an H200 pair: "illegal memory access" on
# the first streams, 2026-11-27); the devices still step at the same time while their threads
# wait for their streams.
HOST_LOCK = threading.Lock()
# How a slot waits for its stream: "block" (the default: one blocking-sync CUDA event per slot,
# waited for in the driver with the lock and the GIL let go) or "poll" (``HARNESS_DEVICE_WAIT=
# poll``, as before: an event queried every ``POLL_S``, the lock and the GIL let go in between;
# sixteen polling device threads of the demo woke 32,000 times a second and fought the threads
# doing host work for the GIL). Measured on two H200 boxes, 2026-11-27, the demo sweep one run
# each per box: 105.8 s and 101.1 s polling, 79.0 s and 69.6 s blocking (first outcomes after
# 47-60 s and 26-44 s). Where Warp does not expose the event flags, slots poll.
WAIT_ENV = "HARNESS_DEVICE_WAIT"
_BLOCKING_SYNC = 0x1 | 0x2  # cudaEventBlockingSync | cudaEventDisableTiming


def _native() -> Any:
    """Warp's native library (its event flags and a synchronize without the capture check are
    not public), or None where this Warp does not have it there (then slots poll)."""
    try:
        from warp._src.context import runtime
    except ImportError:
        return None
    return runtime.core


def blocking_event(device: str) -> Any:
    """A CUDA event of ``device`` whose synchronize sleeps in the driver (no spinning core),
    or None where this Warp does not expose the event flags (then the slot polls)."""
    native = _native()
    if native is None:
        return None
    dev = wp.get_device(device)
    handle = native.wp_cuda_event_create(dev.context, _BLOCKING_SYNC)
    if not handle:
        return None
    event = wp.Event(dev, cuda_event=handle)
    event.owner = True  # destroyed with the slot (Warp frees the events it owns)
    return event


class DeviceSlot:
    """A stream of ``device`` (``None``: the device's current one) and the device's lock."""

    def __init__(self, device: str, lock: Any = None, stream: Any = None) -> None:
        self.device = device
        self.lock = lock if lock is not None else HOST_LOCK
        self.stream = stream
        self.cuda = wp.get_device(device).is_cuda
        blocking = self.cuda and os.environ.get(WAIT_ENV, "block") != "poll"
        self._event = blocking_event(device) if blocking else None  # made once, reused
        self._mark_event = blocking_event(device) if blocking else None  # ``mark``'s

    @classmethod
    def several(cls, device: str, count: int) -> list[DeviceSlot]:
        """``count`` slots of ``device`` sharing the host lock, each with a stream of its own."""
        lock = HOST_LOCK
        cuda = wp.get_device(device).is_cuda
        return [cls(device, lock, wp.Stream(device) if cuda else None) for _ in range(count)]

    def __enter__(self) -> DeviceSlot:
        self.lock.acquire()
        self._make_current()
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        self.lock.release()

    def _make_current(self) -> None:
        wp.set_device(self.device)
        if self.stream is not None:
            wp.set_stream(self.stream, self.device)

    @contextmanager
    def released(self) -> Iterator[None]:
        """(Holding the lock) let the other slots have it meanwhile: for host work that issues no
        Warp call (judging, waiting for jobs); held again, with this slot current, afterwards."""
        self.lock.release()
        try:
            yield
        finally:
            self.lock.acquire()
            self._make_current()

    def launch(self, graph: Any, times: int = 1) -> None:
        """Replay a captured ``graph`` ``times`` times on this slot's stream (holding the lock
        on entry and on return). A launch blocks while the device's queue for the stream is
        full, for about the graph's own device time when the graph is long, so the lock is let
        go meanwhile (once for all ``times``) and the other slots launch theirs: held through
        it, eight demo streams stepped one after another (a sampling profile, 2026-11-27: 64 s
        of the streams' time inside ``capture_launch``, all under the lock). The calls name
        their stream, so they do not depend on Warp's process-wide current stream. A graph's
        first launch instantiates it and stays under the lock, as do the launches of a slot
        without a stream of its own."""
        if self.stream is None:
            for _ in range(times):
                wp.capture_launch(graph)
            return
        if times > 0 and getattr(graph, "graph_exec", None) is None:
            wp.capture_launch(graph)
            times -= 1
        if times <= 0:
            return
        self.lock.release()
        try:
            for _ in range(times):
                wp.capture_launch(graph, stream=self.stream)
        finally:
            self.lock.acquire()
            self._make_current()

    def mark(self) -> Any:
        """An event recorded on this slot's stream after the work queued so far (None on a
        slot without a stream: the CPU device runs its work as it is issued). One mark is out
        at a time: ``wait_mark`` it before the next."""
        if not self.cuda:
            return None
        if self._mark_event is None:
            return wp.record_event()
        self._record(self._mark_event)
        return self._mark_event

    def wait_mark(self, mark: Any) -> None:
        """Wait (holding the lock on entry and on return) until the work queued before
        ``mark`` is done; later work may still run."""
        if mark is None:
            return
        if mark is self._mark_event:
            self._sync_blocking(mark)
        else:
            self._poll(mark)

    def wait(self) -> None:
        """Wait (holding the lock on entry and on return) until this slot's queued work is done;
        the other slots issue theirs meanwhile."""
        if not self.cuda:
            wp.synchronize_device(self.device)
            return
        if self._event is not None:
            self._record(self._event)
            self._sync_blocking(self._event)
            return
        self._poll(wp.record_event())

    def _record(self, event: Any) -> None:
        if self.stream is not None:
            self.stream.record_event(event)
        else:
            wp.record_event(event)

    def _poll(self, event: Any) -> None:
        """Query ``event`` every ``POLL_S``, the lock let go in between."""
        while not event.is_complete:
            self.lock.release()
            try:
                time.sleep(POLL_S)
            finally:  # held again whatever happens, as ``__exit__`` expects
                self.lock.acquire()
        self._make_current()

    def _sync_blocking(self, event: Any) -> None:
        """Wait for a recorded blocking-sync event with the lock let go (the native call
        releases the GIL while the driver sleeps). ``wp.synchronize_event`` refuses while any
        thread captures a graph on the device (a tug round may, another slot's thread), which a
        CUDA event synchronize from this thread does not disturb, so the native call is made
        directly."""
        native = _native()
        assert native is not None  # the event was made through it
        self.lock.release()
        try:
            if not native.wp_cuda_event_synchronize(event.cuda_event):
                raise RuntimeError(f"waiting for a stream of {self.device} failed")
        finally:
            self.lock.acquire()
        self._make_current()
