"""How a process pool's worker (``harness.runs.executors``) starts, how long a busy worker may
overrun, how often a crash is retried."""

from __future__ import annotations

import contextlib
import signal
import sys
import types
from collections.abc import Iterator
from typing import Any

from harness.files import WRITE_TIMEOUT_S

# A worker that dies mid-episode (segfault, OOM kill) gets its episode run again this many
# times before the episode is stored as an ``error`` row.
CRASH_RETRIES = 1

# A worker still busy this long after its episode's ``limits.wall_time_s`` is killed and the
# episode stored as ``timeout`` (the episode's own checks and alarm end it at the limit; this
# is the backstop for code that neither checks nor lets the alarm in, e.g. a long C call). The
# grace covers the recording write after the episode (bounded by files.WRITE_TIMEOUT_S).
KILL_GRACE_S = WRITE_TIMEOUT_S + 30.0


@contextlib.contextmanager
def main_module_hidden() -> Iterator[None]:
    """Start a spawned worker without re-running the caller's script.

    A spawned child imports the parent's ``__main__`` by path, which re-runs a script's top level
    and, without an ``if __name__ == "__main__":`` guard, makes a script that calls
    ``harness.sweep`` fail. The worker's target lives in this package and needs nothing from
    ``__main__``, so the main module is hidden from the spawn preparation for the start.
    """
    main = sys.modules.get("__main__")
    stand_in = types.ModuleType("__main__")
    sys.modules["__main__"] = stand_in
    try:
        yield
    finally:
        if main is not None:
            sys.modules["__main__"] = main


def start_worker(process: Any) -> None:
    """Start a pool's worker ``process`` with SIGINT blocked, and the parent's ``__main__``
    hidden (``main_module_hidden``). Ctrl-C goes to the whole terminal process group; the
    worker ignores SIGINT once its main runs, but a signal during its start-up (imports) would
    kill it and look like a crash. The child inherits the signal mask across fork + exec, so
    only the parent ever sees Ctrl-C, and it stops the workers itself."""
    blocked = hasattr(signal, "pthread_sigmask")
    if blocked:
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        with main_module_hidden():
            process.start()
    finally:
        if blocked:
            signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
