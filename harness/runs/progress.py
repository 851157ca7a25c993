"""Progress of long commands: a rich bar on a terminal, plain lines everywhere else.

On a terminal the sweep shows a rich bar (episodes per second, time left, the running success
rate). Without one (CI, ``nohup``, a pipe) a bar prints nothing until it ends, so
``ProgressLines`` prints ``LABEL: done/total UNIT (p%), r/s, ETA ...`` every
``progress_interval()`` seconds (``EVERY_S`` unless the command's ``--progress-every`` set it),
whether or not anything finished since the last line, and a last line when it ends; a job done
before the first line prints nothing.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable
from typing import Any, TextIO

EVERY_S = 30.0  # the bound: a silent log longer than this looks hung
# The shortest interval ``--progress-every`` takes (chosen: a line a second is already a log of
# its own; shorter ones would drown the run's other lines).
MIN_EVERY_S = 1.0
_EVERY_S = [EVERY_S]  # this process's interval (``set_progress_interval``)


def progress_interval() -> float:
    """Seconds between plain progress lines in this process (``EVERY_S`` unless set)."""
    return _EVERY_S[0]


def set_progress_interval(seconds: float) -> None:
    """The interval of this process's plain progress lines (``--progress-every``; > 0)."""
    if not seconds > 0:
        raise ValueError(f"a progress interval is a positive number of seconds, not {seconds}")
    _EVERY_S[0] = float(seconds)


def stdout_is_terminal() -> bool:
    try:
        return sys.stdout.isatty()
    except (AttributeError, ValueError):  # a replaced or closed stdout
        return False


def duration(seconds: float) -> str:
    """``47s``, ``3m05s``, ``1h02m``: short, for progress lines."""
    seconds = max(0, round(seconds))
    if seconds < 60:
        return f"{seconds}s"
    if seconds < 3600:
        return f"{seconds // 60}m{seconds % 60:02d}s"
    return f"{seconds // 3600}h{seconds % 3600 // 60:02d}m"


class ProgressLines:
    """``LABEL: done/total UNIT (p%), rate UNIT/s, ETA t[, NOTE]`` on ``stream`` every
    ``every_s`` seconds from a daemon thread, from ``start()`` until ``stop()``."""

    def __init__(
        self,
        label: str,
        total: int,
        *,
        already: int = 0,
        unit: str = "episodes",
        every_s: float | None = None,
        stream: TextIO | None = None,
    ) -> None:
        self.label, self.total, self.already, self.unit = label, total, already, unit
        self.every_s = every_s if every_s is not None else progress_interval()
        self.stream = stream
        self.done = 0  # finished in this process (the rate counts only these)
        self.note = ""
        self.printed = 0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()
        self.start_time = time.monotonic()

    def start(self) -> ProgressLines:
        self.start_time = time.monotonic()
        self._thread = threading.Thread(target=self._tick, name="progress-lines", daemon=True)
        self._thread.start()
        return self

    def advance(self, count: int = 1, note: str = "") -> None:
        self.done += count
        if note:
            self.note = note

    def line(self) -> str:
        elapsed = max(time.monotonic() - self.start_time, 1e-9)
        finished = self.already + self.done
        share = f" ({finished / self.total:.0%})" if self.total else ""
        rate = self.done / elapsed
        if self.done:
            left = max(self.total - finished, 0) / rate
            eta = f"ETA {duration(left)}"
        else:
            eta = f"ETA - (none finished in {duration(elapsed)})"
        note = f", {self.note}" if self.note else ""
        return (
            f"{self.label}: {finished}/{self.total} {self.unit}{share}, "
            f"{rate:.2f} {self.unit}/s, {eta}{note}"
        )

    def _print(self, text: str) -> None:
        with self._lock:
            try:
                print(text, file=self.stream or sys.stdout, flush=True)
            except (OSError, ValueError):  # a closed pipe: progress is not worth a failure
                return
            self.printed += 1

    def _tick(self) -> None:
        while not self._stop.wait(self.every_s):
            self._print(self.line())

    def stop(self) -> None:
        """End the ticks; a job that printed a line prints its last one (time taken)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
        if self.printed:
            took = duration(time.monotonic() - self.start_time)
            finished = self.already + self.done
            self._print(f"{self.label}: {finished}/{self.total} {self.unit} in {took}")

    def __enter__(self) -> ProgressLines:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()


class SweepProgress:
    """Rich progress bar with episodes per second, time left and the running success rate on a
    terminal; ``ProgressLines`` (``label``) without one."""

    def __init__(
        self,
        total: int,
        already: int,
        enabled: bool,
        workers: int | None = None,
        label: str = "sweep",
    ) -> None:
        self.total = total
        # Until the first row arrives the bar says what is happening (spawning workers, imports
        # and scene builds take seconds), not "0.00 ep/s".
        self.starting = f"starting {workers} worker(s)" if workers else "starting"
        self.already = already
        self.enabled = enabled
        self.successes = 0
        self.finished = 0
        self.label = label
        self.lines: ProgressLines | None = None

    def __enter__(self) -> Callable[[dict[str, Any]], None]:
        if not self.enabled:
            return self._count
        if not stdout_is_terminal():
            self.lines = ProgressLines(self.label, self.total, already=self.already).start()
            self.lines.note = self.starting
            return self._line
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        self.bar = Progress(
            TextColumn("[bold]{task.fields[status]}"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("{task.fields[rate]:.2f} ep/s"),
            TextColumn("success {task.fields[success]}"),
            TimeElapsedColumn(),
            TextColumn("left"),
            TimeRemainingColumn(),
        )
        self.bar.start()
        self.task_id = self.bar.add_task(
            self.label,
            total=self.total,
            completed=self.already,
            rate=0.0,
            success="-",
            status=self.starting,
        )
        self.start = time.perf_counter()
        return self._advance

    def _count(self, row: dict[str, Any]) -> None:
        self.finished += 1
        self.successes += bool(row.get("success"))

    def _line(self, row: dict[str, Any]) -> None:
        self._count(row)
        if self.lines is not None:
            self.lines.advance(note=f"success {self.successes}/{self.finished}")

    def _advance(self, row: dict[str, Any]) -> None:
        self._count(row)
        elapsed = max(time.perf_counter() - self.start, 1e-9)
        self.bar.update(
            self.task_id,
            advance=1,
            rate=self.finished / elapsed,
            success=f"{self.successes}/{self.finished}",
            status=self.label,
        )

    def __exit__(self, *exc: object) -> None:
        if self.lines is not None:
            self.lines.stop()
        elif self.enabled:
            self.bar.stop()
