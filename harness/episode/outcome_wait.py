"""Waiting for a candidate's outcome that another episode of the same seed is executing.

Points that differ only in their selection keys share a seed's evaluations
(``harness.episode.candidate_cache``): when two of them choose the same candidate, the second
reuses the first's executed outcome instead of executing it again. On the CPU engine the share
group's episodes run one after another, so the outcome is always there. With a shared device
(``harness.runs.device_pool``) the next episode of a group starts planning as soon as the one
before hands its job to the device, so it may choose a candidate whose execution is still in
flight: it then waits for that outcome (``InFlight``) rather than executing it twice.

How a thread waits is the process's business: a device worker's episode threads must hand the
worker's baton on while they wait (else nothing else plans) and pause their wall-clock budget
(the wait is not their work). ``set_waiter`` installs that; the default simply blocks.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

# How the calling thread waits for ``event``: blocks until it is set.
Waiter = Callable[[threading.Event], None]


def _block(event: threading.Event) -> None:
    event.wait()


_waiter: Waiter = _block


def set_waiter(waiter: Waiter | None) -> None:
    """How this process's episode threads wait for an outcome in flight (None: block)."""
    global _waiter
    _waiter = waiter if waiter is not None else _block


class InFlight:
    """The candidates of one seed whose execution an episode has started and not finished."""

    def __init__(self) -> None:
        self._events: dict[int, threading.Event] = {}
        self._lock = threading.Lock()

    def claim(self, pose_index: int) -> bool:
        """Mark ``pose_index`` as executing by the caller (False: another episode executes it)."""
        with self._lock:
            if pose_index in self._events:
                return False
            self._events[pose_index] = threading.Event()
            return True

    def finish(self, pose_index: int) -> None:
        """The caller's execution of ``pose_index`` ended (its outcome is stored, or it failed)."""
        with self._lock:
            event = self._events.pop(pose_index, None)
        if event is not None:
            event.set()

    def wait(self, pose_index: int) -> None:
        """Until no episode executes ``pose_index`` (returns at once when none does)."""
        with self._lock:
            event = self._events.get(pose_index)
        if event is not None:
            _waiter(event)
