"""The process pool with ``--engine mjwarp``: workers plan without waiting for the device.

Each worker holds up to ``depth`` *tracks*, each a share group (the points of one seed that
differ only in their selection keys) whose episodes start one after another, each in a thread
of its own; one thread plans at a time (``harness.engines.mjwarp.service.Baton``). When an
episode reaches its execution, its job goes to the parent (``DeviceRequest``), which queues it
on the devices' lane streams (``DeviceService``), and the track's next episode starts planning
at once: it reuses the candidate cache the one before filled, exactly as on the CPU engine, and
when it chooses a candidate whose execution is still on the device it waits for that outcome
instead of executing it again (``harness.episode.outcome_wait``). So a group's episodes are on
the device together, not one device latency after another. Once every thread of a worker waits
for the device, the worker is given another share group. Outcomes come back as they are judged;
the episode's thread builds the row as the in-process engine does and sends it (``EpisodeRow``).

What the CPU pool guarantees holds here: every row is stored as it arrives; a worker that dies
turns the episode it was planning into a retried or ``error`` row and its other episodes are run
again elsewhere; a worker that keeps one episode past its wall-clock limit (plus
``KILL_GRACE_S``) while planning is killed and that episode is a ``timeout`` row (time waiting
for the device, the baton or another episode's outcome does not count); Ctrl-C stops the run
and keeps what finished.
"""

from __future__ import annotations

import contextlib
import functools
import os
import signal
import sys
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import TYPE_CHECKING, Any

from harness.runs.scheduling import share_groups
from harness.runs.spawning import CRASH_RETRIES, KILL_GRACE_S, start_worker
from harness.runs.thread_budget import box_episode_threads, depth_for, starved_note

if TYPE_CHECKING:
    from harness.engines.mjwarp.service import DeviceReply, DeviceService
    from harness.episode.spec import EpisodeSpec
    from harness.runs.run_stats import OnResult, RunStats


@dataclass
class EpisodeStart:
    """Parent to worker: run ``episode`` in a new episode thread, ``thread``."""

    thread: int
    episode: EpisodeSpec


@dataclass
class EpisodeRow:
    """Worker to parent: the row of episode thread ``thread``."""

    thread: int
    row: dict[str, Any]


@dataclass
class Holding:
    """Worker to parent: episode thread ``thread`` holds the baton (plans) from now on
    (``None``: the holder waits for another episode's outcome, no thread plans)."""

    thread: int | None


def device_worker_main(
    conn: Connection, run_dir: str, record: str, share: bool, depth: int = 1
) -> None:
    """Process-pool worker with the shared devices: each ``EpisodeStart`` runs in a thread
    holding the baton; ``DeviceReply`` messages go to the thread waiting for them. ``depth``:
    the share groups the worker holds at once (its candidate cache keeps every one of them)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C (and SIGTERM)
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    from harness.runs.sampler import start_from_env

    stop_profile = start_from_env(f".worker-{os.getpid()}")  # HARNESS_SAMPLE_PROFILE
    try:
        _serve_worker(conn, run_dir, record, share, depth)
    finally:
        stop_profile()


def _serve_worker(conn: Connection, run_dir: str, record: str, share: bool, depth: int) -> None:
    """``device_worker_main``'s loop: episode threads started, replies delivered."""
    from harness.engines import register_engine
    from harness.engines.mjwarp.service import Baton, DeviceReply, PooledDeviceEngine
    from harness.episode.outcome_wait import set_waiter
    from harness.runs.worker import execute, reserve_candidate_cache

    send_lock = threading.Lock()

    def send(message: Any) -> None:
        with send_lock:
            conn.send(message)

    baton = Baton(lambda thread: send(Holding(thread)))
    register_engine(PooledDeviceEngine(send, baton))
    set_waiter(baton.wait_elsewhere)
    reserve_candidate_cache(depth)

    def run(thread: int, episode: EpisodeSpec) -> None:
        baton.hold(thread)
        try:
            row = execute(episode, run_dir, record, share)
        finally:
            baton.release()
        with contextlib.suppress(BrokenPipeError, OSError):
            send(EpisodeRow(thread, row))

    while True:
        try:
            message = conn.recv()
        except (EOFError, OSError):  # the parent is gone: nothing to report to
            return
        if message is None:
            return
        if isinstance(message, DeviceReply):
            baton.deliver(message)
        elif isinstance(message, EpisodeStart):
            threading.Thread(
                target=run, args=(message.thread, message.episode), daemon=True
            ).start()


@dataclass
class _Thread:
    """An episode running in a worker's thread."""

    track: int
    episode: EpisodeSpec
    on_device: bool = False
    waiting: bool = False  # for an outcome another thread's job will bring (``Holding(None)``)
    started: float = field(default_factory=time.monotonic)  # its life: to its row


@dataclass
class _Track:
    """A share group on a worker: the episodes still to start (next last), the thread that
    plans its latest episode until that one's job goes to the device (None: none), and every
    thread of it whose row has not come."""

    group: list[EpisodeSpec]
    head: int | None = None
    threads: set[int] = field(default_factory=set)


@dataclass
class _Worker:
    process: Any
    conn: Connection
    send_lock: threading.Lock = field(default_factory=threading.Lock)
    tracks: dict[int, _Track] = field(default_factory=dict)
    threads: dict[int, _Thread] = field(default_factory=dict)
    holder: int | None = None  # the episode thread planning now
    holder_since: float = 0.0  # monotonic, with the device waits of that thread taken out
    next_id: int = 0  # of tracks and threads alike

    def send(self, message: Any) -> None:
        """Send, ignoring a worker that died meanwhile (its sentinel reports it)."""
        with self.send_lock, contextlib.suppress(BrokenPipeError, OSError):
            self.conn.send(message)

    def new_id(self) -> int:
        self.next_id += 1
        return self.next_id

    def planning(self) -> bool:
        """Some episode thread of this worker is not waiting for the device."""
        return any(not (t.on_device or t.waiting) for t in self.threads.values())


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
        threads: int | None = None,
    ) -> None:
        """``threads``: the most episode threads of this pool's workers (``depth_for``; a
        device process gets its share of the box's, ``box_episode_threads``)."""
        import multiprocessing as mp

        self.context = mp.get_context("spawn")
        self.run_dir, self.record, self.share = run_dir, record, share
        self.on_result, self.stats = on_result, stats
        groups = share_groups(episodes) if share else [[e] for e in episodes]
        group = max((len(g) for g in groups), default=1)  # a thread per episode of a group
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
        service.streams.prepare()  # device models load while the workers start
        threads = box_episode_threads() if threads is None else threads
        lanes = service.streams.planned_lanes()
        self.depth = depth_for(lanes, 1, self.count, threads, group)
        say = f"{self.count} worker(s) x {self.depth} group(s) of up to {group} ({threads} threads)"
        print(f"mjwarp: {say}{starved_note(lanes, threads, len(episodes))}", file=sys.stderr)
        self._lock = threading.Lock()  # holder bookkeeping touched by the device threads

    # ---- workers

    def spawn(self) -> _Worker:
        parent, child = self.context.Pipe()
        process = self.context.Process(
            target=device_worker_main,
            args=(child, str(self.run_dir), self.record, self.share, self.depth),
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
        track_id = worker.new_id()
        worker.tracks[track_id] = _Track(group)
        self.start_next(worker, track_id)
        return True

    def start_next(self, worker: _Worker, track_id: int) -> None:
        """Start the track's next episode in a new thread of the worker (if one is left)."""
        track = worker.tracks[track_id]
        if not track.group:
            return
        thread = worker.new_id()
        episode = track.group.pop()
        worker.threads[thread] = _Thread(track_id, episode)
        track.head = thread
        track.threads.add(thread)
        worker.send(EpisodeStart(thread, episode))

    def feed(self, worker: _Worker) -> None:
        """While every thread of ``worker`` waits for the device, open another track (up to
        depth)."""
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
                    self.holding(worker, message.thread)
                elif isinstance(message, DeviceRequest):
                    self.device_request(worker, message)
                elif isinstance(message, EpisodeRow):
                    self.row(worker, message)
        if worker.process.sentinel in ready or not worker.process.is_alive():
            self.died(worker)

    def holding(self, worker: _Worker, thread_id: int | None) -> None:
        """``thread_id`` plans from now on; ``None``: the holder waits for another thread's
        outcome (neither planning nor counted towards its deadline), so its track's next
        episode starts."""
        with self._lock:
            held_by = worker.holder
            holder = worker.threads.get(held_by) if held_by is not None else None
            if thread_id in worker.threads:
                worker.threads[thread_id].waiting = False
            worker.holder, worker.holder_since = thread_id, time.monotonic()
        if thread_id is None and holder is not None and held_by is not None:
            holder.waiting = True  # its planning is done: the track's next episode may start
            self.advance(worker, holder.track, held_by)
            self.feed(worker)

    def device_request(self, worker: _Worker, request: Any) -> None:
        """A thread's job: to the devices; its track's next episode starts planning."""
        thread = worker.threads.get(request.track)  # the request's track: its episode thread
        if thread is None:
            return
        thread.on_device = True
        with self._lock:
            if worker.holder == request.track:
                worker.holder = None
        answer = functools.partial(self.answer, worker, request.track)
        self.device.submit((id(worker), request.track), request.job, answer, request.track)
        self.advance(worker, thread.track, request.track)
        self.feed(worker)

    def advance(self, worker: _Worker, track_id: int, thread: int) -> None:
        """``thread`` no longer plans its track's latest episode: start the next one."""
        track = worker.tracks.get(track_id)
        if track is not None and track.head == thread:
            track.head = None
            self.start_next(worker, track_id)

    def answer(self, worker: _Worker, thread_id: int, reply: DeviceReply) -> None:
        """(A device thread) send the worker its thread's outcome."""
        thread = worker.threads.get(thread_id)
        if thread is not None:
            thread.on_device = False
        worker.send(reply)

    def row(self, worker: _Worker, message: EpisodeRow) -> None:
        self.on_result(message.row)
        self.stats.finished += 1
        with self._lock:
            if worker.holder == message.thread:
                worker.holder = None
        thread = worker.threads.pop(message.thread, None)
        if thread is not None:
            self.stats.lives += 1
            self.stats.lives_s += time.monotonic() - thread.started
            self.advance(worker, thread.track, message.thread)  # it never reached the device
            track = worker.tracks.get(thread.track)
            if track is not None:
                track.threads.discard(message.thread)
                if not track.threads and not track.group:
                    worker.tracks.pop(thread.track)
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
        self.requeue_rest(worker)
        culprit = worker.holder
        for thread_id, thread in worker.threads.items():
            if thread_id == culprit or culprit is None:
                self.retry_or_fail(thread.episode, reason)
            else:
                self.requeued.append([thread.episode])
        if self.pending_work():
            self.start()

    def requeue_rest(self, worker: _Worker) -> None:
        """The episodes of a lost worker's tracks that had not started: to run elsewhere."""
        for track in worker.tracks.values():
            if track.group:
                self.requeued.append(track.group)

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
            thread = worker.threads.get(worker.holder) if worker.holder is not None else None
            if thread is None or thread.on_device:
                return None
            runs = 2 if self.share and (thread.episode.record or self.record == "failures") else 1
            limit = runs * thread.episode.task.limits.wall_time_s
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
            self.requeue_rest(worker)
            culprit = worker.holder
            for thread_id, thread in worker.threads.items():
                if thread_id != culprit:
                    self.requeued.append([thread.episode])
                    continue
                limit = thread.episode.task.limits.wall_time_s
                row = error_row(
                    thread.episode,
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
