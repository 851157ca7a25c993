"""What an executor reports when its run ends (``RunStats``) and the row callback's type."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

OnResult = Callable[[dict[str, Any]], None]


@dataclass
class RunStats:
    """Episodes finished, worker crashes and retries, whether Ctrl-C stopped the run, its wall
    time, error lines, and when each row arrived."""

    finished: int = 0
    crashed: int = 0  # episodes whose worker died on every attempt (stored as ``error`` rows)
    retried: int = 0  # worker deaths whose episode was run again
    interrupted: bool = False
    wall_time_s: float = 0.0
    errors: list[str] = field(default_factory=list)
    # when each row of this call arrived, seconds from the executor's start (``harness.runs.pace``)
    arrivals: list[float] = field(default_factory=list)
