"""The process pool with ``--engine mjwarp``: workers plan without waiting for the device.

Each worker holds up to ``depth`` *tracks*, each a share group run one episode after another in a
thread of its own (so the rest of a group reuses the candidate cache exactly as on the CPU
engine); one thread plans at a time (``harness.engines.mjwarp.service.Baton``). When an
episode reaches its execution, its job goes to the parent (``DeviceRequest``), which queues it
on the devices' lane streams (``DeviceService``), and the worker goes on planning: once every
track of a worker waits for the device, the worker is given another share group. Outcomes come
back as they are judged; the track's thread builds the row as the in-process engine does and
sends it (``TrackRow``), and the track takes the next episode of its group.

What the CPU pool guarantees holds here: every row is stored as it arrives; a worker that dies
turns the episode it was planning into a retried or ``error`` row and its other episodes are run
again elsewhere; a worker that keeps one episode past its wall-clock limit (plus
``KILL_GRACE_S``) while planning is killed and that episode is a ``timeout`` row (time waiting
for the device or the baton does not count); Ctrl-C stops the run and keeps what finished.
"""

from __future__ import annotations

import contextlib
import functools
import math
import os
import signal
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import TYPE_CHECKING, Any

from harness.runs.scheduling import share_groups
from harness.runs.spawning import CRASH_RETRIES, KILL_GRACE_S, start_worker

if TYPE_CHECKING:
    from harness.engines.mjwarp.service import DeviceReply, DeviceService
    from harness.episode.spec import EpisodeSpec
    from harness.runs.executors import OnResult, RunStats

# The most episodes a worker holds at once (one planning, the others waiting for the device).
# Chosen, no public source: the lanes need about two jobs in flight per lane to stay full
# (``depth_for``); past this a worker's threads cost more memory than they feed.
MAX_DEPTH = 1024


def depth_for(lanes: int, devices: int, workers: int) -> int:
    """Episodes per worker so that the workers together keep every device's lanes fed (two
    jobs per lane: one stepping, one planned or judged), at least 2."""
    return max(2, min(MAX_DEPTH, math.ceil(2 * lanes * devices / max(1, workers))))


@dataclass
class TrackEpisode:
    """Parent to worker: run ``episode`` on track ``track``."""

    track: int
    episode: EpisodeSpec


@dataclass
class TrackRow:
    """Worker to parent: the row of track ``track``'s episode."""

    track: int
    row: dict[str, Any]


@dataclass
class Holding:
    """Worker to parent: track ``track`` holds the baton (plans) from now on."""

    track: int


def device_worker_main(conn: Connection, run_dir: str, record: str, share: bool) -> None:
    """Process-pool worker with the shared devices: each ``TrackEpisode`` runs in a thread
    holding the baton; ``DeviceReply`` messages go to the thread waiting for them."""
    from harness.engines import register_engine
    from harness.engines.mjwarp.service import Baton, DeviceReply, PooledDeviceEngine
    from harness.runs.worker import execute

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C (and SIGTERM)
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    send_lock = threading.Lock()

    def send(message: Any) -> None:
        with send_lock:
            conn.send(message)

    baton = Baton(lambda track: send(Holding(track)))
    register_engine(PooledDeviceEngine(send, baton))

    def run(track: int, episode: EpisodeSpec) -> None:
        baton.hold(track)
        try:
            row = execute(episode, run_dir, record, share)
        finally:
            baton.release()
        with contextlib.suppress(BrokenPipeError, OSError):
            send(TrackRow(track, row))

    while True:
        try:
            message = conn.recv()
        except (EOFError, OSError):  # the parent is gone: nothing to report to
            return
        if message is None:
            return
        if isinstance(message, DeviceReply):
            baton.deliver(message)
        elif isinstance(message, TrackEpisode):
            threading.Thread(target=run, args=(message.track, message.episode), daemon=True).start()


@dataclass
class _Track:
    episode: EpisodeSpec
    group: list[EpisodeSpec]  # the rest of its share group, next last
    on_device: bool = False


@dataclass
class _Worker:
    process: Any
    conn: Connection
    send_lock: threading.Lock = field(default_factory=threading.Lock)
    tracks: dict[int, _Track] = field(default_factory=dict)
    holder: int | None = None  # the track planning now
    holder_since: float = 0.0  # monotonic, with the device waits of that track taken out
    next_track: int = 0

    def send(self, message: Any) -> None:
        """Send, ignoring a worker that died meanwhile (its sentinel reports it)."""
        with self.send_lock, contextlib.suppress(BrokenPipeError, OSError):
            self.conn.send(message)

    def planning(self) -> bool:
        """Some track of this worker is not waiting for the device."""
        return any(not t.on_device for t in self.tracks.values())


class DevicePool:
    """The pool's workers and their tracks, the groups still to hand out, the devices."""

    def __init__(
        self,
        episodes: list[EpisodeSpec],
        run_dir: Path,
        record: str,
        on_result: OnResult,
        stats: RunStats,
        workers: int,
        share: bool = True,
        service: DeviceService | None = None,
    ) -> None:
        import multiprocessing as mp

        self.context = mp.get_context("spawn")
        self.run_dir, self.record, self.share = run_dir, record, share
        self.on_result, self.stats = on_result, stats
        groups = share_groups(episodes) if share else [[e] for e in episodes]
        self.pending: Iterator[list[EpisodeSpec]] = iter(groups)
        self.requeued: list[list[EpisodeSpec]] = []  # groups (or their rests) to run again
        self.attempts: dict[str, int] = {}
        self.workers: list[_Worker] = []
        self.count = max(1, min(workers, len(episodes)))
        if service is None:
            from harness.engines.mjwarp.service import DeviceService

            service = DeviceService()
        self.device = service
        service.streams.episodes = len(episodes)
        try:  # each task model's stream gets lanes for its own jobs
            service.streams.expect(e.task for e in episodes)
        except Exception:  # a task that cannot be read fails as its episode's row
            service.streams.expected = {}
        self.depth = depth_for(service.streams.planned_lanes(), 1, self.count)
        self._lock = threading.Lock()  # holder bookkeeping touched by the device threads

    # ---- workers

    def spawn(self) -> _Worker:
        parent, child = self.context.Pipe()
        process = self.context.Process(
            target=device_worker_main,
            args=(child, str(self.run_dir), self.record, self.share),
            daemon=True,
        )
        start_worker(process)  # SIGINT blocked while it starts (runs.spawning)
        child.close()
        worker = _Worker(process, parent)
        self.workers.append(worker)
        return worker

    def start(self) -> None:
        worker = self.spawn()
        self.open_track(worker)

    def next_group(self) -> list[EpisodeSpec]:
        if self.requeued:
            return self.requeued.pop()
        return list(reversed(next(self.pending, [])))

    def open_track(self, worker: _Worker) -> bool:
        """Give ``worker`` a new share group on a new track (False: none is left)."""
        group = self.next_group()
        if not group:
            return False
        track = worker.next_track
        worker.next_track += 1
        worker.tracks[track] = _Track(group.pop(), group)
        worker.send(TrackEpisode(track, worker.tracks[track].episode))
        return True

    def feed(self, worker: _Worker) -> None:
        """While every track of ``worker`` waits for the device, open another (up to depth)."""
        while not worker.planning() and len(worker.tracks) < self.depth:
            if not self.open_track(worker):
                return

    def busy(self) -> bool:
        return any(w.tracks for w in self.workers)

    # ---- messages

    def collect(self, worker: _Worker, ready: list[Any]) -> None:
        """Take every message ``worker`` sent, or replace it if it died."""
        from harness.engines.mjwarp.service import DeviceRequest

        if worker.conn in ready:
            while True:
                try:
                    if not worker.conn.poll():
                        break
                    message = worker.conn.recv()
                except (EOFError, OSError):
                    break
                if isinstance(message, Holding):
                    with self._lock:
                        worker.holder, worker.holder_since = message.track, time.monotonic()
                elif isinstance(message, DeviceRequest):
                    self.device_request(worker, message)
                elif isinstance(message, TrackRow):
                    self.row(worker, message)
        if worker.process.sentinel in ready or not worker.process.is_alive():
            self.died(worker)

    def device_request(self, worker: _Worker, request: Any) -> None:
        track = worker.tracks.get(request.track)
        if track is None:
            return
        track.on_device = True
        with self._lock:
            if worker.holder == request.track:
                worker.holder = None
        answer = functools.partial(self.answer, worker, request.track)
        self.device.submit((id(worker), request.track), request.job, answer, request.track)
        self.feed(worker)

    def answer(self, worker: _Worker, track_id: int, reply: DeviceReply) -> None:
        """(A device thread) send the worker its track's outcome."""
        track = worker.tracks.get(track_id)
        if track is not None:
            track.on_device = False
        worker.send(reply)

    def row(self, worker: _Worker, message: TrackRow) -> None:
        self.on_result(message.row)
        self.stats.finished += 1
        track = worker.tracks.get(message.track)
        with self._lock:
            if worker.holder == message.track:
                worker.holder = None
        if track is not None and track.group:
            track.episode = track.group.pop()
            track.on_device = False
            worker.send(TrackEpisode(message.track, track.episode))
        else:
            worker.tracks.pop(message.track, None)
            if not worker.tracks:
                self.open_track(worker)
        self.feed(worker)

    # ---- failures

    def died(self, worker: _Worker) -> None:
        """A dead worker: the episode it was planning is retried (then an ``error`` row), its
        other episodes run again on a new worker."""
        worker.process.join(timeout=1)
        code = worker.process.exitcode
        reason = (
            f"worker crashed (signal {-code})"
            if code and code < 0
            else f"worker exited with code {code}"
        )
        self.workers.remove(worker)
        culprit = worker.holder
        for track_id, track in worker.tracks.items():
            if track.group:
                self.requeued.append(track.group)
            if track_id == culprit or culprit is None:
                self.retry_or_fail(track.episode, reason)
            else:
                self.requeued.append([track.episode])
        if self.pending_work():
            self.start()

    def pending_work(self) -> bool:
        return bool(self.requeued) or any(w.tracks for w in self.workers) or self._peek()

    def _peek(self) -> bool:
        group = next(self.pending, None)
        if group is None:
            return False
        self.requeued.append(list(reversed(group)))
        return True

    def retry_or_fail(self, episode: EpisodeSpec, reason: str) -> None:
        from harness.runs.worker import error_row

        attempts = self.attempts.get(episode.resolved_id, 0) + 1
        self.attempts[episode.resolved_id] = attempts
        if attempts <= CRASH_RETRIES:
            self.requeued.append([episode])
            self.stats.retried += 1
            return
        suffix = f" ({attempts} attempts)" if attempts > 1 else ""
        self.on_result(error_row(episode, reason + suffix))
        self.stats.finished += 1
        self.stats.crashed += 1

    def next_deadline(self) -> float | None:
        """Seconds until the first planning episode's kill deadline (None: none planning)."""
        deadlines = [self._deadline(w) for w in self.workers]
        deadlines = [d for d in deadlines if d is not None]
        return max(0.0, min(deadlines) - time.monotonic()) if deadlines else None

    def _deadline(self, worker: _Worker) -> float | None:
        with self._lock:
            track = worker.tracks.get(worker.holder) if worker.holder is not None else None
            if track is None or track.on_device:
                return None
            runs = 2 if self.share and (track.episode.record or self.record == "failures") else 1
            limit = runs * track.episode.task.limits.wall_time_s
            return worker.holder_since + limit + KILL_GRACE_S

    def kill_overdue(self) -> None:
        """Kill a worker whose planning episode is past its deadline: that episode is a
        ``timeout`` row, the worker's other episodes run again."""
        from harness.runs.worker import error_row

        now = time.monotonic()
        for worker in list(self.workers):
            deadline = self._deadline(worker)
            if deadline is None or now <= deadline or worker.conn.poll():
                continue
            worker.process.kill()
            worker.process.join(timeout=5)
            self.workers.remove(worker)
            culprit = worker.holder
            for track_id, track in worker.tracks.items():
                if track.group:
                    self.requeued.append(track.group)
                if track_id != culprit:
                    self.requeued.append([track.episode])
                    continue
                limit = track.episode.task.limits.wall_time_s
                row = error_row(
                    track.episode,
                    f"wall-clock limit of {limit:g} s reached: the worker was still busy "
                    f"{KILL_GRACE_S:g} s after it and was killed",
                )
                row["failure_reason"] = "timeout"
                self.on_result(row)
                self.stats.finished += 1
            if self.pending_work():
                self.start()

    def shutdown(self) -> None:
        self.device.stop(interrupted=self.stats.interrupted)
        for worker in self.workers:
            if self.stats.interrupted:
                worker.process.terminate()
            else:
                worker.send(None)
        for worker in self.workers:
            worker.process.join(timeout=5)
            if worker.process.is_alive():
                worker.process.kill()


def run_device_pool(pool: DevicePool) -> None:
    """Run the pool until every episode's row is stored (or Ctrl-C)."""
    stats = pool.stats
    start = time.perf_counter()
    try:
        for _ in range(pool.count):
            pool.start()
        while pool.busy():
            busy = [w for w in pool.workers if w.tracks]
            handles = [w.conn for w in busy] + [w.process.sentinel for w in busy]
            timeout = pool.next_deadline()
            ready = wait(handles, timeout=1.0 if timeout is None else min(timeout, 1.0))
            for worker in busy:
                if worker in pool.workers:
                    pool.collect(worker, ready)
            pool.kill_overdue()
    except KeyboardInterrupt:
        stats.interrupted = True
    finally:
        pool.shutdown()
    stats.device = pool.device.stats
    stats.wall_time_s = time.perf_counter() - start
