"""A process per device: with several Warp devices, each runs its own device pool.

One process did not feed two GPUs (issue 34, two H200s: the second GPU's stream stepped 3,537 of
16,866 stream-steps, and at 8,192 lanes each step took 11.95 ms): every stream's host work
shared one interpreter lock and one host lock. Here the sweep's share groups are split between
the devices (``split_groups``: whole groups, so sharing holds; the fewest episodes first), and
each device gets a *shard* process of its own (``HARNESS_WARP_DEVICE`` set to that device) that
runs the usual ``harness.runs.device_pool`` with its share of the planning workers. Rows come
back to this process as they finish and go to ``on_result`` (one writer, one progress bar);
each shard's ``RunStats`` come back when it ends and are summed (``merge_stats``).

Ctrl-C reaches only this process (the shards start with SIGINT blocked, as pool workers do): it
tells every shard to stop, each stops its pool as Ctrl-C would and sends what it finished, so
nothing finished is lost. A shard that dies leaves an ``error`` row, naming its device, for
each of its episodes without a row. ``HARNESS_PROCESS_PER_DEVICE=0`` keeps one process for all
devices (the behaviour before), ``1`` a process per device whatever the run's size; unset, a
run gets a process per device when each device has ``SHARD_MIN_EPISODES`` of its episodes.
"""

from __future__ import annotations

import _thread
import os
import queue
import signal
import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from harness.runs.scheduling import share_groups
from harness.runs.spawning import start_worker
from harness.runs.thread_budget import box_episode_threads

if TYPE_CHECKING:
    from harness.episode.spec import EpisodeSpec
    from harness.runs.run_stats import OnResult, RunStats

# How long a stopped shard gets to send what it finished before it is terminated (its pool
# stops its workers in seconds; chosen, no public source).
STOP_GRACE_S = 60.0
# The fewest episodes per device for a process each. A smaller run is latency-bound on one
# device (issue 34's 3,000-row FR3 sweep: 53.9 s on one H200, 58.0 s on two from one process)
# and a process per device would load every device model again for each run, where one process
# keeps them between a tune's rounds (``devices._ENGINES``). Chosen, no public source: a
# stream's most lanes (``lane_sizes.CUDA_LANES``) for each device.
SHARD_MIN_EPISODES = 8192
# The signal a shard's stop thread raises in its main thread (SIGINT is ignored there: a
# Ctrl-C during its start-up would kill it mid-import).
STOP_SIGNAL = signal.SIGUSR1
STOP_POLL_S = 0.2  # how often a shard's watcher looks at the parent's stop (chosen)


def warp_devices() -> list[str]:
    """The devices a device pool would use (``default_devices``); none without the gpu extra
    (the pool then says so itself, once, as its episodes' rows)."""
    from harness.engines.mjwarp.engine import default_devices
    from harness.errors import HarnessError

    try:
        return default_devices()
    except HarnessError:
        return []


def process_per_device(devices: list[str], episodes: int) -> bool:
    """A process per device for a run of ``episodes`` on ``devices``: with several devices,
    when each gets at least ``SHARD_MIN_EPISODES`` (``HARNESS_PROCESS_PER_DEVICE``: ``1``
    always, ``0`` never)."""
    chosen = os.environ.get("HARNESS_PROCESS_PER_DEVICE", "").strip()
    if len(devices) < 2 or chosen == "0":
        return False
    return chosen == "1" or episodes >= SHARD_MIN_EPISODES * len(devices)


def split_groups(
    episodes: list[EpisodeSpec], shards: int, share: bool = True
) -> list[list[EpisodeSpec]]:
    """``episodes`` in ``shards`` lists of whole share groups (every episode of a group in one
    list), each group to the list with the fewest episodes so far, in the sweep's order."""
    groups = share_groups(episodes) if share else [[e] for e in episodes]
    split: list[list[EpisodeSpec]] = [[] for _ in range(shards)]
    for group in groups:
        min(split, key=len).extend(group)
    return split


def split_workers(workers: int, sizes: list[int]) -> list[int]:
    """``workers`` planning processes shared in proportion to the shards' ``sizes``, at least
    one each (largest remainders get the rest)."""
    total = sum(sizes) or 1
    exact = [workers * size / total for size in sizes]
    counts = [max(1, int(share)) for share in exact]
    order = sorted(range(len(sizes)), key=lambda k: exact[k] - int(exact[k]), reverse=True)
    for k in order[: max(0, workers - sum(counts))]:
        counts[k] += 1
    return counts


def merge_stats(total: RunStats, shard: RunStats) -> None:
    """Add a shard's ``RunStats`` to ``total``: counts and errors summed, interrupted if any
    was; its devices' ``StreamStats`` as devices that ran side by side (``add_side_by_side``)."""
    total.finished += shard.finished
    total.crashed += shard.crashed
    total.retried += shard.retried
    total.lives += shard.lives
    total.lives_s += shard.lives_s
    total.interrupted = total.interrupted or shard.interrupted
    total.errors.extend(shard.errors)
    if shard.device is None:
        return
    if total.device is None:
        total.device = shard.device
        return
    from harness.engines.mjwarp.stream_stats import add_side_by_side

    add_side_by_side(total.device, shard.device)


def shard_main(
    index: int,
    device: str,
    episodes: list[EpisodeSpec],
    run_dir: str,
    record: str,
    workers: int,
    share: bool,
    out: Any,
    stop: Any,
    threads: int,
) -> None:
    """Shard ``index``: the device pool of ``episodes`` on ``device`` (its workers with at most
    ``threads`` episode threads); each row, then its stats, to ``out`` with the index. ``stop``
    set by the parent ends the pool as Ctrl-C would."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's; it sets ``stop``
    state = {"running": False, "stopped": False}

    def interrupt(signum: int, frame: Any) -> None:
        """The stop, in the main thread: Ctrl-C's KeyboardInterrupt while the pool runs."""
        state["stopped"] = True
        if state["running"]:
            raise KeyboardInterrupt

    signal.signal(STOP_SIGNAL, interrupt)
    os.environ["HARNESS_WARP_DEVICE"] = device
    os.environ["HARNESS_PROCESS_PER_DEVICE"] = "0"  # this shard is one device's process

    ended = threading.Event()

    def stop_when_told() -> None:
        while not ended.is_set():
            if stop.wait(STOP_POLL_S):
                _thread.interrupt_main(STOP_SIGNAL)
                return

    watcher = threading.Thread(target=stop_when_told, daemon=True)
    watcher.start()
    from harness.runs.device_pool import DevicePool, run_device_pool
    from harness.runs.run_stats import RunStats

    stats = RunStats()
    pool = DevicePool(
        episodes, Path(run_dir), record, lambda row: out.put((index, row)), stats, workers, share,
        threads=threads,
    )  # fmt: skip
    state["running"] = True
    try:
        if state["stopped"]:  # stopped while the pool was built: nothing started
            stats.interrupted = True
            pool.shutdown()
        else:
            run_device_pool(pool)  # a KeyboardInterrupt ends it as Ctrl-C does
    finally:
        state["running"] = False
        ended.set()
    watcher.join()
    out.put((index, stats))


class _Shard:
    def __init__(self, device: str, episodes: list[EpisodeSpec], process: Any) -> None:
        self.device, self.process = device, process
        self.left = {e.resolved_id: e for e in episodes}  # episodes without a row yet
        self.done = False


def run_device_shards(
    episodes: list[EpisodeSpec],
    run_dir: Path,
    record: str,
    on_result: OnResult,
    workers: int,
    devices: list[str],
    share: bool = True,
) -> RunStats:
    """Every device's share of ``episodes`` in a shard process of its own (module docstring)."""
    import multiprocessing as mp

    from harness.runs.run_stats import RunStats

    context = mp.get_context("spawn")
    out, stop = context.Queue(), context.Event()
    split = split_groups(episodes, len(devices), share)
    counts = split_workers(workers, [len(part) for part in split])
    threads = box_episode_threads() // len(devices)  # the box's episode threads, per device
    shards: list[_Shard] = []
    for device, part, count in zip(devices, split, counts, strict=True):
        if not part:
            continue
        process = context.Process(
            target=shard_main,
            args=(len(shards), device, part, str(run_dir), record, count, share, out, stop),
            kwargs={"threads": threads},
            daemon=False,  # a shard starts pool workers of its own
        )
        start_worker(process)
        shards.append(_Shard(device, part, process))
    stats = RunStats()
    start = time.perf_counter()
    try:
        _collect(shards, out, on_result, stats, deadline=None)
    except KeyboardInterrupt:
        stats.interrupted = True
        stop.set()
        _collect(shards, out, on_result, stats, deadline=time.monotonic() + STOP_GRACE_S)
    finally:
        for shard in shards:
            shard.process.join(timeout=5)
            if shard.process.is_alive():
                shard.process.kill()
    stats.wall_time_s = time.perf_counter() - start
    return stats


def _collect(
    shards: list[_Shard], out: Any, on_result: OnResult, stats: RunStats, deadline: float | None
) -> None:
    """Rows to ``on_result`` and stats into ``stats`` until every shard is done, has died (its
    episodes without a row become ``error`` rows) or ``deadline`` passed (the shards still
    running are terminated; the rows they had sent are kept)."""
    while any(not shard.done for shard in shards):
        overdue = deadline is not None and time.monotonic() > deadline
        try:
            index, payload = out.get_nowait() if overdue else out.get(timeout=1.0)
        except queue.Empty:
            if overdue:
                for shard in shards:
                    if not shard.done:
                        shard.process.terminate()
                        shard.done = True
                return
            for shard in shards:
                if not shard.done and shard.process.exitcode is not None:
                    _lost(shard, on_result, stats, stopping=deadline is not None)
            continue
        shard = shards[index]
        if isinstance(payload, dict):  # a row
            shard.left.pop(str(payload.get("episode_id")), None)
            on_result(payload)
        else:  # the shard's RunStats: it ended
            shard.done = True
            merge_stats(stats, payload)


def _lost(shard: _Shard, on_result: OnResult, stats: RunStats, stopping: bool) -> None:
    """A shard that died without its stats: an ``error`` row for each episode it left, unless
    the run is stopping (they stay unfinished, for the same command to continue)."""
    from harness.runs.worker import error_row

    shard.done = True
    code = shard.process.exitcode
    if stopping:
        return
    for episode in shard.left.values():
        on_result(
            error_row(episode, f"the device process of {shard.device} died (exit code {code})")
        )
        stats.finished += 1
        stats.crashed += 1
    stats.errors.append(f"{shard.device}: the device process died (exit code {code})")
    shard.left.clear()
