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
# Expansion checks every (task, point) pair (~15 ms each: overrides, filters): a 100 x 100 grid
# took 97 s before its first episode and `validate` over 120 s, whatever its episode count. Above
# this many pairs a sweep is refused at once (raise with --max-points). Chosen, no public source:
# ~30 s of expansion on one core, and 40x the largest shipped sweep.
MAX_POINTS = 2_000


def planned_points(sweep: SweepConfig) -> int:
    """Points a sweep asks for (grid product, or random draws), from the axis lengths only."""
    if sweep.mode == "grid":
        return math.prod(len(values) for values in sweep.axes.values()) if sweep.axes else 1
    return sweep.points


def planned_episodes(sweep: SweepConfig, task_count: int) -> int:
    """Episodes a sweep asks for: tasks x points x episodes per point."""
    return task_count * planned_points(sweep) * sweep.episodes_per_point


def check_sweep_size(
    sweep: SweepConfig,
    task_count: int,
    limit: int = MAX_EPISODES,
    max_points: int | None = MAX_POINTS,
    file: str | Path | None = None,
) -> int:
    """The planned episode count, or a ConfigError when it exceeds ``limit`` episodes or
    ``max_points`` (task, point) pairs (``None``: no point limit, for generated grids)."""
    pairs = task_count * planned_points(sweep)
    if max_points is not None and pairs > max_points:
        raise ConfigError(
            f"sweep {sweep.name!r} has {pairs:,} (task, point) pairs ({task_count} task(s) x "
            f"{planned_points(sweep):,} points), above the limit of {max_points:,} (each is "
            f"checked before the first episode, ~15 ms apiece); shrink the axes or pass "
            f"--max-points {pairs}",
            file=file,
            key="axes" if sweep.mode == "grid" else "points",
        )
    count = planned_episodes(sweep, task_count)
    if count > limit:
        raise ConfigError(
            f"sweep {sweep.name!r} asks for {count:,} episodes ({task_count} task(s) x points x "
            f"{sweep.episodes_per_point} per point), above the limit of {limit:,}; shrink the "
            f"axes or pass --max-episodes {count}",
            file=file,
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
