"""The sweep's progress bar: episodes per second, time left and the running success rate."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any


class SweepProgress:
    """Rich progress bar with episodes per second, time left and the running success rate."""

    def __init__(self, total: int, already: int, enabled: bool, workers: int | None = None) -> None:
        self.total = total
        # Until the first row arrives the bar says what is happening (spawning workers, imports
        # and scene builds take seconds), not "0.00 ep/s".
        self.starting = f"starting {workers} worker(s)" if workers else "starting"
        self.already = already
        self.enabled = enabled
        self.successes = 0
        self.finished = 0

    def __enter__(self) -> Callable[[dict[str, Any]], None]:
        if not self.enabled:
            return self._count
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
            "sweep",
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

    def _advance(self, row: dict[str, Any]) -> None:
        self._count(row)
        elapsed = max(time.perf_counter() - self.start, 1e-9)
        self.bar.update(
            self.task_id,
            advance=1,
            rate=self.finished / elapsed,
            success=f"{self.successes}/{self.finished}",
            status="sweep",
        )

    def __exit__(self, *exc: object) -> None:
        if self.enabled:
            self.bar.stop()
