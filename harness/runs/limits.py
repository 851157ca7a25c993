"""Size limits of a sweep, checked before anything is expanded or run.

Expansion costs ~15 ms per point and a run ~1 s per episode per core, so a typo such as a
300 x 300 grid or ``episodes_per_point: 100000`` would sit silently for hours. The count is
computed from the axis lengths (nothing is materialised) and refused above ``MAX_EPISODES``
with a message that says how to raise the limit.
"""

from __future__ import annotations

import math
from pathlib import Path

from harness.config import ConfigError, SweepConfig

MAX_EPISODES = 200_000  # ~1 day of episodes on 2 cores; raise with --max-episodes
MAX_EPISODES_ENV = "PICK_HARNESS_MAX_EPISODES"


def planned_episodes(sweep: SweepConfig, task_count: int) -> int:
    """Episodes a sweep asks for: tasks x points x episodes per point."""
    if sweep.mode == "grid":
        points = math.prod(len(values) for values in sweep.axes.values()) if sweep.axes else 1
    else:
        points = sweep.points
    return task_count * points * sweep.episodes_per_point


def check_sweep_size(sweep: SweepConfig, task_count: int, limit: int = MAX_EPISODES) -> int:
    """The planned episode count, or a ConfigError when it exceeds ``limit``."""
    count = planned_episodes(sweep, task_count)
    if count > limit:
        raise ConfigError(
            f"sweep {sweep.name!r} asks for {count:,} episodes ({task_count} task(s) x points x "
            f"{sweep.episodes_per_point} per point), above the limit of {limit:,}; shrink the "
            f"axes or pass --max-episodes {count}"
        )
    return count


# A run whose ``error`` rows exceed this share of its rows exits non-zero: errors are crashes or
# input problems, never picks, and a sweep that is mostly errors must not look finished.
MAX_ERROR_SHARE = 0.05


def error_rows_line(errors: int, rows: int, run_dir: Path) -> str | None:
    """One line saying how many rows are ``error`` and where they are listed (None if none)."""
    if not errors:
        return None
    share = errors / rows if rows else 1.0
    return (
        f"{errors} of {rows} episode(s) ({share:.0%}) are error rows, not counted in any success "
        f"rate; listed with their error_message in {run_dir / 'episodes.csv'} "
        f"(failure_reason == error)"
    )


def too_many_errors(errors: int, rows: int) -> bool:
    """True when ``error`` rows exceed ``MAX_ERROR_SHARE`` of the run's rows."""
    return errors > MAX_ERROR_SHARE * rows
