"""A run's pace from the times its rows arrived: its steady rate, start-up and tail aside.

A run's wall time mixes a fixed start (workers importing, scenes compiling, the first episodes)
with its streaming rate, so two runs of different sizes compare badly on wall time alone. The
steady rate here is the rows between the ``STEADY_FROM`` and ``STEADY_TO`` quantiles of arrival
over the time between them.
"""

from __future__ import annotations

import bisect
import time
from dataclasses import dataclass

# The arrivals that bound the steady part of a run (quantiles of its rows). Chosen, no public
# source: the first tenth holds the start-up, the last the tail.
STEADY_FROM = 0.1
STEADY_TO = 0.9
# The fewest rows whose pace is worth a line.
MIN_ROWS = 100


class Arrivals:
    """When each row of a run arrives, in seconds from this object's making (just before the
    executor starts)."""

    def __init__(self) -> None:
        self.start = time.perf_counter()
        self.times: list[float] = []

    def mark(self) -> None:
        self.times.append(time.perf_counter() - self.start)


@dataclass(frozen=True)
class Pace:
    """``rows`` rows arrived in the ``seconds`` after the ``STEADY_FROM`` quantile's row up to
    the ``STEADY_TO`` quantile's; ``tenths``: the rows arrived by the end of each tenth of the
    run's wall time."""

    rows: int
    seconds: float
    tenths: list[int]

    @property
    def per_hour(self) -> float:
        return 3600.0 * self.rows / self.seconds if self.seconds > 0 else float("inf")


def pace_of(arrivals: list[float], wall_s: float) -> Pace | None:
    """The pace of rows that arrived at ``arrivals`` (seconds from the run's start, in order)
    of a run of ``wall_s`` (at least the last arrival); None below ``MIN_ROWS`` rows."""
    n = len(arrivals)
    if n < MIN_ROWS:
        return None
    wall_s = max(wall_s, arrivals[-1])
    first, last = int(STEADY_FROM * n), int(STEADY_TO * n) - 1
    tenths = [bisect.bisect_right(arrivals, wall_s * k / 10) for k in range(1, 11)]
    return Pace(last - first, arrivals[last] - arrivals[first], tenths)


def pace_line(arrivals: list[float], wall_s: float) -> str | None:
    """``pace: ...`` for the sweep's summary, or None (too few rows)."""
    pace = pace_of(arrivals, wall_s)
    if pace is None:
        return None
    low, high = round(100 * STEADY_FROM), round(100 * STEADY_TO)
    return (
        f"pace: {pace.rows} rows ({low}%-{high}% arrivals) in {pace.seconds:.1f} s = "
        f"{pace.per_hour:,.0f} episodes/h; rows by tenths of the wall: "
        + " ".join(str(count) for count in pace.tenths)
    )
