"""The machine under a benchmark: who else uses its CPUs, and what scaling it can deliver.

Not a section (``harness bench`` runs the modules listed in
``harness.benchmarks.framework.SECTIONS``): helpers
the sections use to make their numbers interpretable on a shared machine.

- ``load_average()``: the kernel's 1/5/15-minute run-queue averages.
- ``cpu_snapshot()`` / ``cpu_use_between()``: CPU time spent by *other* processes between two
  snapshots (all CPUs' busy time from ``/proc/stat`` minus this process and its waited-for
  children), plus hypervisor steal time. More direct than the load average, which is smoothed
  over a minute and counts our own processes.
- ``calibrate_scaling()``: a CPU-bound pure-Python loop run in 1 process and then in N
  processes at once (started together after spawning, so start-up is excluded). Its ratio is
  the scaling this machine can give *right now* to perfectly parallel work -- the reference
  for the sweep's 1 -> 2 worker scaling.
- ``spawned_children_peak_mb()``: the true peak memory of live worker processes.
- ``one_core()``: pin this process to one CPU for a measurement "on one core".
"""

from __future__ import annotations

import multiprocessing as mp
import os
import resource
import statistics
import time
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from dataclasses import dataclass
from multiprocessing.connection import Connection

# Pure-Python iterations of the calibration loop; ~0.3-0.4 s on a current x86 core.
CALIBRATION_ITERATIONS = 5_000_000


def load_average() -> list[float] | None:
    """The 1, 5 and 15 minute load averages, or None where the platform has none."""
    try:
        return [round(value, 2) for value in os.getloadavg()]
    except (AttributeError, OSError):
        return None


def usable_cpus() -> int:
    """CPUs this process may run on (its affinity mask), else the machine's CPU count."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


@dataclass(frozen=True)
class CpuSnapshot:
    """CPU time counters at one instant (seconds)."""

    wall_s: float
    busy_s: float | None  # all CPUs, every process (None without /proc/stat)
    steal_s: float | None  # time the hypervisor gave our virtual CPUs to someone else
    own_s: float  # this process + its terminated, waited-for children (user + system)


@dataclass(frozen=True)
class CpuUse:
    """Average CPU use between two snapshots, in CPUs (1.0 = one CPU fully busy)."""

    wall_s: float
    own_cpus: float
    others_cpus: float | None
    steal_cpus: float | None

    def describe(self) -> str:
        if self.others_cpus is None:
            return f"own {self.own_cpus:.2f} CPUs (others unknown: no /proc/stat)"
        return (
            f"other processes used {self.others_cpus:.2f} CPUs, we used {self.own_cpus:.2f}, "
            f"steal {self.steal_cpus or 0.0:.2f}"
        )


def _proc_stat() -> tuple[float, float] | tuple[None, None]:
    """(busy, steal) seconds summed over all CPUs since boot, from the ``cpu`` line."""
    try:
        with open("/proc/stat", encoding="ascii") as handle:
            fields = handle.readline().split()
    except OSError:
        return None, None
    if not fields or fields[0] != "cpu":
        return None, None
    ticks = [int(value) for value in fields[1:]]
    user, nice, system, _idle, _iowait, irq, softirq = ticks[:7]
    steal = ticks[7] if len(ticks) > 7 else 0
    hz = os.sysconf("SC_CLK_TCK")
    return (user + nice + system + irq + softirq) / hz, steal / hz


def _own_cpu_s() -> float:
    total = 0.0
    for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN):
        usage = resource.getrusage(who)
        total += usage.ru_utime + usage.ru_stime
    return total


def cpu_snapshot() -> CpuSnapshot:
    busy, steal = _proc_stat()
    return CpuSnapshot(time.perf_counter(), busy, steal, _own_cpu_s())


def cpu_use_between(before: CpuSnapshot, after: CpuSnapshot) -> CpuUse:
    """CPU use between two snapshots. Take ``after`` once every child has been joined: a
    running child's CPU time is not yet in RUSAGE_CHILDREN and would count as "others"."""
    wall = max(after.wall_s - before.wall_s, 1e-9)
    own = (after.own_s - before.own_s) / wall
    if before.busy_s is None or after.busy_s is None:
        return CpuUse(wall, own, None, None)
    others = max(0.0, (after.busy_s - before.busy_s) / wall - own)
    steal = (after.steal_s or 0.0) - (before.steal_s or 0.0)
    return CpuUse(wall, own, others, steal / wall)


def spawned_children_peak_mb() -> dict[int, float]:
    """Peak resident memory (VmHWM, MiB) of each live ``multiprocessing`` spawn child of this
    process, by pid; {} where /proc is unavailable.

    Read from the parent because a spawned child's own ``ru_maxrss`` is useless for this: Linux
    carries the parent's RSS high-water mark across the fork + exec into the child's
    ``ru_maxrss``, so a small worker of a large parent reports the parent's size. VmHWM belongs
    to the child's own address space."""
    me = os.getpid()
    peaks: dict[int, float] = {}
    try:
        entries = os.listdir("/proc")
    except OSError:
        return {}
    for entry in entries:
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat", encoding="ascii", errors="replace") as handle:
                parent = int(handle.read().rsplit(")", 1)[1].split()[1])
            if parent != me:
                continue
            with open(f"/proc/{entry}/cmdline", "rb") as handle:
                if b"multiprocessing.spawn" not in handle.read():
                    continue
            with open(f"/proc/{entry}/status", encoding="ascii", errors="replace") as handle:
                for line in handle:
                    if line.startswith("VmHWM:"):
                        peaks[int(entry)] = int(line.split()[1]) / 1024
                        break
        except (OSError, ValueError, IndexError):
            continue  # the process ended while we looked
    return peaks


# --------------------------------------------------------------------------------------------
# Calibration: the scaling the machine gives to perfectly parallel CPU-bound work


def spin(iterations: int) -> int:
    """A CPU-bound loop: integer arithmetic in the interpreter, no memory traffic to speak of."""
    total = 0
    for i in range(iterations):
        total += i * i % 7
    return total


def _spin_worker(conn: Connection, iterations: int) -> None:
    """Child process: on each ``True`` received, run the loop and send back its seconds."""
    while conn.recv():
        begin = time.perf_counter()
        spin(iterations)
        conn.send(time.perf_counter() - begin)


@dataclass(frozen=True)
class ScalingCalibration:
    """Rounds of: the loop in one process alone, then in ``processes`` processes at once."""

    processes: int
    single_s: list[float]  # per round
    parallel_s: list[list[float]]  # per round, per process

    @property
    def scalings(self) -> list[float]:
        """Per round: throughput with ``processes`` loops over throughput with one."""
        return [
            self.processes * single / max(parallel)
            for single, parallel in zip(self.single_s, self.parallel_s, strict=True)
        ]

    @property
    def scaling(self) -> float:
        """The median round's scaling (ideal: ``processes``)."""
        return statistics.median(self.scalings)


def calibrate_scaling(
    processes: int = 2, rounds: int = 3, iterations: int = CALIBRATION_ITERATIONS
) -> ScalingCalibration:
    """Measure the machine's scaling to ``processes`` CPU-bound processes (see module doc).

    The processes are spawned once and kept; each round runs the loop in the first process
    alone, then in all at once, so spawn and import time never enter the measurement."""
    context = mp.get_context("spawn")
    pipes: list[Connection] = []
    workers = []
    for _ in range(processes):
        parent, child = context.Pipe()
        worker = context.Process(target=_spin_worker, args=(child, iterations), daemon=True)
        worker.start()
        child.close()
        pipes.append(parent)
        workers.append(worker)

    def run(count: int) -> list[float]:
        for conn in pipes[:count]:
            conn.send(True)
        seconds = []
        for conn, worker in zip(pipes[:count], workers, strict=False):
            while not conn.poll(1.0):
                if not worker.is_alive():
                    raise RuntimeError(f"calibration process died (exit code {worker.exitcode})")
            seconds.append(conn.recv())
        return seconds

    try:
        run(processes)  # warm-up: every interpreter started and the loop's code paths hot
        single, parallel = [], []
        for _ in range(rounds):
            single.append(run(1)[0])
            parallel.append(run(processes))
    finally:
        for conn in pipes:
            with suppress(OSError):
                conn.send(False)
        for worker in workers:
            worker.join(timeout=10)
            if worker.is_alive():
                worker.kill()
                worker.join(timeout=10)
    return ScalingCalibration(processes, single, parallel)


def _per_cpu_busy() -> dict[int, float]:
    """Busy ticks per CPU since boot (``cpuN`` lines of /proc/stat); {} where unavailable."""
    busy: dict[int, float] = {}
    try:
        with open("/proc/stat", encoding="ascii") as handle:
            for line in handle:
                name, *values = line.split()
                if name.startswith("cpu") and name != "cpu":
                    ticks = [int(value) for value in values[:7]]
                    busy[int(name[3:])] = sum(ticks) - ticks[3] - ticks[4]  # minus idle, iowait
    except (OSError, ValueError):
        return {}
    return busy


def least_busy_cpu(allowed: set[int], sample_s: float = 0.2) -> int:
    """The allowed CPU with the least busy time over a short sample (others' work lands there
    less); the lowest-numbered one when /proc/stat is unavailable."""
    before = _per_cpu_busy()
    time.sleep(sample_s)
    after = _per_cpu_busy()
    candidates = [cpu for cpu in sorted(allowed) if cpu in before and cpu in after]
    if not candidates:
        return min(allowed)
    return min(candidates, key=lambda cpu: after[cpu] - before[cpu])


@contextmanager
def one_core() -> Iterator[str]:
    """Pin this process to a single CPU for the duration (Linux); yields a note for the figure.

    The CPU is the least busy one at the start, so on a shared machine the measurement does not
    sit on the core another process is hogging."""
    if not hasattr(os, "sched_setaffinity"):
        yield "not pinned (no sched_setaffinity on this platform)"
        return
    before = os.sched_getaffinity(0)
    cpu = least_busy_cpu(before)
    os.sched_setaffinity(0, {cpu})
    try:
        yield f"pinned to CPU {cpu}"
    finally:
        os.sched_setaffinity(0, before)
