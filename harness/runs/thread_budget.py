"""How many episode threads the device pools of one box may start: the kernel's limits, read.

With ``--engine mjwarp`` every episode in flight holds a thread in its worker (planning, or
waiting for its outcome), and the lanes need several episodes a lane in flight
(``IN_FLIGHT_PER_LANE``), so a box's threads bound the lanes it can feed. Linux counts a
thread as a task: each takes a PID below ``/proc/sys/kernel/pid_max`` and counts against
``/proc/sys/kernel/threads-max``, the cgroup's ``pids.max`` and ``RLIMIT_NPROC`` (proc(5),
setrlimit(2), the kernel's cgroup-v2 pids controller). On two H200s (2026-11-28) a box of
~30,000 threads failed with ``can't start new thread``, as it would under the default
``pid_max`` of 32,768.

The pools get ``EPISODE_SHARE`` of the least of those limits; the rest is for every other task
on the box (each process's own threads: the interpreter's, Warp's, BLAS's, the pipes').
``depth_for`` turns the budget into share groups per worker: a group's episodes each hold a
thread (three cones of one seed: three threads), which the first cut of this bound missed (two
H200s, 2026-11-28: 15 workers x 546 groups of three, ``can't start new thread`` again).
"""

from __future__ import annotations

import math
import resource
from pathlib import Path

# The part of the box's task limit the episode threads may take. Chosen, no public source: the
# rest covers the processes' own threads and whatever else runs on the box.
EPISODE_SHARE = 0.5
# Where no limit can be read (not Linux): the most threads a box has been seen to start with
# room to spare (8,200 threads on two H200s, 2026-11-28, docs/engines.md).
UNKNOWN_LIMIT_THREADS = 8192
# Fewest episode threads, whatever the limits say (a pool needs a planning and a waiting one a
# worker; a box that cannot start these fails loudly anyway).
MIN_THREADS = 64

KERNEL_FILES = (
    Path("/proc/sys/kernel/pid_max"),
    Path("/proc/sys/kernel/threads-max"),
    Path("/sys/fs/cgroup/pids.max"),
)


def read_limit(path: Path) -> int | None:
    """The integer in ``path`` (``max``, a missing or unreadable file: no limit)."""
    try:
        text = path.read_text().strip()
    except OSError:
        return None
    return int(text) if text.isdigit() else None


def task_limit(files: tuple[Path, ...] = KERNEL_FILES) -> int | None:
    """The least of the kernel's limits on this box's tasks (threads), None where none is set."""
    limits = [limit for path in files if (limit := read_limit(path)) is not None]
    soft, _ = resource.getrlimit(resource.RLIMIT_NPROC)
    if soft != resource.RLIM_INFINITY and soft > 0:
        limits.append(int(soft))
    return min(limits) if limits else None


def box_episode_threads(files: tuple[Path, ...] = KERNEL_FILES) -> int:
    """The episode threads every device pool of this box may hold together: ``EPISODE_SHARE``
    of ``task_limit``, else ``UNKNOWN_LIMIT_THREADS``."""
    limit = task_limit(files)
    if limit is None:
        return UNKNOWN_LIMIT_THREADS
    return max(MIN_THREADS, int(limit * EPISODE_SHARE))


# The most share groups a device-pool worker holds at once (one planning, the others waiting
# for the device). Chosen, no public source: past this a worker's threads cost more memory than
# they feed.
MAX_DEPTH = 1024
# Episodes in flight per lane (``HARNESS_IN_FLIGHT_PER_LANE`` overrides). A pool's rate is its
# episodes in flight over an episode's life (Little's law): the life is planning, the queue, the
# span in a lane (~40 s for FR3 at 8,192 lanes) and the tug after it, so a lane stays busy only
# with about life / span episodes for it. At 2 a lane (2026-11-28 evening) both FR3 runs
# of 45,000 rows on two H200s were bounded so: one GPU held 16,461 episodes for 278 rows/s (a
# life of 59 s) with its lanes 65% busy, two GPUs 2 x 16,425 for 403 rows/s (81 s) with theirs
# 41% busy and no job queued. On this project's machine a null device that answers after 5 s
# or 20 s gave 4.7 and 1.2 rows/s with 24 episodes in flight (24 / 5, 24 / 20) and 36.8 and
# 34.7 rows/s with 600 (the worker's planning rate, 40.5 rows/s without a delay). Yet 4 a lane
# measured slower end to end, on one two-H200 box (2026-11-28 09:48 UTC, docs/engines.md): the
# 45,000-row FR3 sweep took 263.3 s on both GPUs against 207.3 s at 2 a lane (the evening
# before), and 262.9 s on one GPU against 239.4 s. The steady pace rose (1.86 M against 1.45 M
# episodes/h on two GPUs) but the lanes' host side slowed (10.2 against 8.4 ms a step, uploads
# 26 against 11 s: every episode planned at once competes with the streams for the process and
# the cores) and the first outcomes came after 92 s against 55 s. So 2, chosen on that
# measurement, no public source; about 150 KB of worker memory an episode in flight.
IN_FLIGHT_PER_LANE = 2


def in_flight_per_lane() -> int:
    """``HARNESS_IN_FLIGHT_PER_LANE``, else ``IN_FLIGHT_PER_LANE``."""
    from harness.engines.mjwarp.lane_sizes import env_int

    return env_int("HARNESS_IN_FLIGHT_PER_LANE") or IN_FLIGHT_PER_LANE


def depth_for(
    lanes: int, devices: int, workers: int, threads: int | None = None, group: int = 1
) -> int:
    """Share groups per worker (``group`` episodes each, a thread apiece) so that the workers
    together keep every device's lanes fed (``in_flight_per_lane`` episodes a lane), at least 2,
    with at most ``threads`` episode threads over all the workers (default: the box's,
    ``box_episode_threads``)."""
    workers, group = max(1, workers), max(1, group)
    threads = box_episode_threads() if threads is None else threads
    wanted = math.ceil(in_flight_per_lane() * lanes * devices / (workers * group))
    return max(2, min(MAX_DEPTH, threads // (workers * group), wanted))


def starved_note(lanes: int, threads: int, episodes: int | None = None) -> str:
    """A hint where the pool's episode threads cannot hold what its lanes want in flight
    (``in_flight_per_lane`` a lane, at most the run's ``episodes``): the rows then come at
    what the threads hold over an episode's life (Little's law; the canonical tune's refinement
    on one H100, 2026-11-28: 16,384 threads held 12,000 of its 40,000 episodes, and its lanes
    idled). The limit to raise, else ``""``."""
    wanted = in_flight_per_lane() * lanes
    wanted = wanted if episodes is None else min(wanted, episodes)
    if threads >= wanted:
        return ""
    limit = task_limit()
    return (
        f"; {threads} episode threads for {wanted} episodes in flight ({lanes} lanes): the "
        f"box's task limit ({limit if limit is not None else 'unknown'}) bounds them; raise "
        f"kernel.pid_max (4194304 on 64-bit Linux, what systemd sets) or use fewer lanes "
        f"(HARNESS_LANES)"
    )
