"""Progress of long commands: a rich bar on a terminal, plain lines everywhere else.

On a terminal the sweep shows a rich bar (episodes per second, the running success rate,
``elapsed 0:01:22, 0:00:26 left``). Without one (CI, ``nohup``, a pipe, a notebook) a bar prints
nothing until it ends, so ``ProgressLines`` prints ``LABEL: done/total UNIT (p%), r UNIT/s,
elapsed 0:01:22, 0:00:26 left`` every ``progress_interval()`` seconds (``EVERY_S`` unless the
command's ``--progress-every`` set it), whether or not anything finished since the last line,
and a last line when it ends; a job done before the first line prints nothing. Until the first
episode finishes neither shows a bar, a rate or a time left (none can be known while the
workers import and build their scenes): they say ``starting N workers`` and the time elapsed.
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


def clock(seconds: float) -> str:
    """``0:01:22``: elapsed and remaining times in progress lines and the bar."""
    seconds = max(0, round(seconds))
    return f"{seconds // 3600}:{seconds % 3600 // 60:02d}:{seconds % 60:02d}"


def elapsed_left(elapsed_s: float, left_s: float | None) -> str:
    """``elapsed 0:01:22, 0:00:26 left`` (``elapsed 0:01:22`` while nothing says what is left)."""
    left = f", {clock(left_s)} left" if left_s is not None else ""
    return f"elapsed {clock(elapsed_s)}{left}"


def starting_text(workers: int | None) -> str:
    """``starting 2 workers`` (``starting`` for an in-process run)."""
    if not workers:
        return "starting"
    return f"starting {workers} worker{'s' if workers != 1 else ''}"


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
        self.starting = ""  # said instead of a rate and a time left until the first one ends
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
        """``sweep: 30/400 episodes (8%), 0.50 episodes/s, elapsed 0:01:00, 0:12:20 left, NOTE``;
        before the first one finishes: ``sweep: 0/400 episodes, starting 2 workers, elapsed
        0:00:30`` (no rate and no time left: nothing measures them yet)."""
        elapsed = max(time.monotonic() - self.start_time, 1e-9)
        finished = self.already + self.done
        share = f" ({finished / self.total:.0%})" if self.total else ""
        if not self.done:
            what = self.starting or "none finished yet"
            head = f"{self.label}: {finished}/{self.total} {self.unit}"
            return f"{head}, {what}, {elapsed_left(elapsed, None)}"
        rate = self.done / elapsed
        left = max(self.total - finished, 0) / rate
        note = f", {self.note}" if self.note else ""
        return (
            f"{self.label}: {finished}/{self.total} {self.unit}{share}, "
            f"{rate:.2f} {self.unit}/s, {elapsed_left(elapsed, left)}{note}"
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
        self.starting = starting_text(workers)
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
            self.lines = ProgressLines(self.label, self.total, already=self.already)
            self.lines.starting = self.starting
            self.lines.start()
            return self._line
        from rich.progress import Progress

        self.bar = Progress(*bar_columns())
        self.bar.start()
        self.task_id = self.bar.add_task(
            self.label,
            total=self.total,
            completed=self.already,
            rate=0.0,
            success="-",
            status=self.starting,
            running=False,
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
            running=True,
        )

    def __exit__(self, *exc: object) -> None:
        if self.lines is not None:
            self.lines.stop()
        elif self.enabled:
            self.bar.stop()


BAR_WIDTH = 10  # with 120/400, 0.91/s, success 100/120 and both times the line fits 80 columns


def bar_columns() -> list[Any]:
    """The bar's columns: ``LABEL ━━━━ 30/400 0.50/s success 20/30 elapsed 0:01:00, 0:12:20
    left``; while ``running`` is false (the workers start) only ``starting N workers elapsed
    0:00:12``: no bar, count, rate or time left that nothing has measured yet."""
    from rich.progress import BarColumn, MofNCompleteColumn, ProgressColumn, Task, TextColumn
    from rich.text import Text

    class Running(ProgressColumn):
        """``column`` once the first episode finished, nothing before."""

        def __init__(self, column: ProgressColumn) -> None:
            super().__init__()
            self.column = column

        def render(self, task: Task) -> Any:
            return self.column.render(task) if task.fields.get("running") else Text("")

    class ElapsedLeft(ProgressColumn):
        """``elapsed 0:01:22, 0:00:26 left``; ``elapsed 0:00:12`` until a rate is measured."""

        max_refresh = 0.5

        def render(self, task: Task) -> Text:
            left = task.time_remaining if task.fields.get("running") else None
            return Text(elapsed_left(task.elapsed or 0.0, left), style="progress.elapsed")

    return [
        TextColumn("[bold]{task.fields[status]}"),
        Running(BarColumn(bar_width=BAR_WIDTH)),
        Running(MofNCompleteColumn()),
        Running(TextColumn("{task.fields[rate]:.2f}/s")),
        Running(TextColumn("success {task.fields[success]}")),
        ElapsedLeft(),
    ]
