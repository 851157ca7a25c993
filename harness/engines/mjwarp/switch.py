"""The interpreter's thread switch interval while device streams run.

Every Warp call from a device thread is a driver call that lets go of the GIL; coming back, the
thread waits until the thread holding the GIL lets go of it, at the latest after the switch
interval (Python's default: 5 ms). A visit of a lane stream makes a few dozen such calls
(uploads, launches, downloads), and the demo sweep runs 16 device threads (8 streams, 8 tug
threads) beside the pool's messaging, so a visit can wait for the GIL more than its device work
takes. ``HARNESS_SWITCH_INTERVAL_MS`` sets the interval for the time the device streams run
(the default keeps Python's; not yet measured on a GPU: job ``demo_gpu_switch``).
"""

from __future__ import annotations

import os
import sys

from harness.errors import HarnessError

SWITCH_ENV = "HARNESS_SWITCH_INTERVAL_MS"


def shorten() -> float | None:
    """Set the switch interval from ``HARNESS_SWITCH_INTERVAL_MS``; the one it replaced (s), or
    None when the variable is not set. A value that is not a positive number is one line
    naming the variable."""
    chosen = os.environ.get(SWITCH_ENV, "").strip()
    if not chosen:
        return None
    try:
        ms = float(chosen)
    except ValueError:
        ms = -1.0
    if not ms > 0:
        raise HarnessError(f"{SWITCH_ENV}={chosen!r}: give a positive number of milliseconds")
    before = sys.getswitchinterval()
    sys.setswitchinterval(ms / 1000.0)
    return before


def restore(before: float | None) -> None:
    """Put back the interval ``shorten`` replaced."""
    if before is not None:
        sys.setswitchinterval(before)
