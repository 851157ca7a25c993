"""Executors: serial, process pool and Ray, behind one ``Executor`` protocol.

An executor runs a list of episodes, hands each row to ``on_result`` as soon as it arrives
(the caller stores it), and returns ``RunStats``. A worker that dies (even by a segfault) turns
its episode into an ``error`` row and is replaced; Ctrl-C stops the run and keeps what finished.
"""

from __future__ import annotations

import contextlib
import functools
import math
import multiprocessing as mp
import os
import signal
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from harness.config import ConfigError
from harness.runs.run_stats import OnResult, RunStats
from harness.runs.scheduling import share_groups, shared_order
from harness.runs.spawning import CRASH_RETRIES, KILL_GRACE_S, start_worker
from harness.runs.worker import error_row, execute

if TYPE_CHECKING:
    from harness.episode.spec import EpisodeSpec


def run_serial(
    episodes: list[EpisodeSpec],
    run_dir: Path,
    record: str,
    on_result: OnResult,
    share: bool = True,
) -> RunStats:
    """Every episode in this process, share groups back to back (``harness.runs.scheduling``)."""
    stats = RunStats()
    start = time.perf_counter()
    try:
        for episode in shared_order(episodes) if share else episodes:
            on_result(execute(episode, str(run_dir), record, share))
            stats.finished += 1
    except KeyboardInterrupt:
        stats.interrupted = True
    stats.wall_time_s = time.perf_counter() - start
    return stats


def _worker_main(conn: Connection, run_dir: str, record: str, share: bool) -> None:
    """Process-pool worker: receive episodes on ``conn``, send rows back; scenes stay cached."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C (and SIGTERM)
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    while True:
        try:
            episode = conn.recv()
        except (EOFError, OSError):  # the parent is gone: nothing to report to
            return
        if episode is None:
            return
        row = execute(episode, run_dir, record, share)
        try:
            conn.send(row)
        except (BrokenPipeError, OSError):  # the parent was killed mid-episode
            return


@dataclass
class _Worker:
    process: Any
    conn: Connection
    episode: EpisodeSpec | None = None
    group: list[EpisodeSpec] = field(default_factory=list)  # the rest of its share group
    deadline: float = math.inf  # monotonic time past which the worker is killed


class _ProcessPool:
    """The pool's workers, the episodes still to hand out, and what happened so far."""

    def __init__(
        self,
        episodes: list[EpisodeSpec],
        run_dir: Path,
        record: str,
        on_result: OnResult,
        share: bool = True,
    ) -> None:
        self.context = mp.get_context("spawn")
        self.run_dir = run_dir
        self.record = record
        self.share = share
        self.on_result = on_result
        self.stats = RunStats()
        # A worker runs a whole share group before taking the next (its cache answers the rest
        # of the group); without sharing every episode is a group of its own.
        groups = share_groups(episodes) if share else [[e] for e in episodes]
        self.pending: Iterator[list[EpisodeSpec]] = iter(groups)
        self.requeued: list[EpisodeSpec] = []  # episodes of dead workers, run again first
        self.attempts: dict[str, int] = {}
        self.workers: list[_Worker] = []

    def spawn(self) -> _Worker:
        parent, child = self.context.Pipe()
        process = self.context.Process(
            target=_worker_main,
            args=(child, str(self.run_dir), self.record, self.share),
            daemon=True,
        )
        start_worker(process)  # SIGINT blocked while it starts: only the parent sees Ctrl-C
        child.close()
        return _Worker(process, parent)

    def start(self) -> None:
        """A fresh worker in the pool, given the next episode."""
        worker = self.spawn()
        self.workers.append(worker)
        self.assign(worker)

    def assign(self, worker: _Worker) -> bool:
        if self.requeued:
            episode: EpisodeSpec | None = self.requeued.pop()
        else:
            if not worker.group:
                worker.group = list(reversed(next(self.pending, [])))
            episode = worker.group.pop() if worker.group else None
        worker.episode = episode
        if episode is None:
            worker.deadline = math.inf
            return False
        # A shared episode that must be recorded runs twice (the second time for its trace),
        # each run under the limit.
        runs = 2 if self.share and (episode.record or self.record == "failures") else 1
        limit = runs * episode.task.limits.wall_time_s
        worker.deadline = time.monotonic() + limit + KILL_GRACE_S
        worker.conn.send(episode)
        return True

    def next_deadline(self) -> float | None:
        """Seconds until the first busy worker's kill deadline (None: no busy worker)."""
        deadlines = [w.deadline for w in self.workers if w.episode is not None]
        return max(0.0, min(deadlines) - time.monotonic()) if deadlines else None

    def kill_overdue(self) -> None:
        """Kill each worker past its episode's deadline; the episode is a ``timeout`` row and
        the rest of its share group goes to the next free worker (nothing else is lost)."""
        now = time.monotonic()
        overdue = [w for w in self.workers if w.episode is not None and now > w.deadline]
        for worker in overdue:
            if worker.conn.poll():  # its row arrived meanwhile: collected on the next turn
                continue
            episode = worker.episode
            assert episode is not None
            worker.process.kill()
            worker.process.join(timeout=5)
            self.workers.remove(worker)
            self.requeued.extend(reversed(worker.group))
            limit = episode.task.limits.wall_time_s
            row = error_row(
                episode,
                f"wall-clock limit of {limit:g} s reached: the worker was still busy "
                f"{KILL_GRACE_S:g} s after it and was killed",
            )
            row["failure_reason"] = "timeout"
            self.on_result(row)
            self.stats.finished += 1
            self.start()

    def collect(self, worker: _Worker, ready: list[Any]) -> None:
        """Take a busy worker's row if it sent one, or replace it if it died."""
        if worker.conn in ready:
            try:
                row = worker.conn.recv()
            except (EOFError, OSError):
                row = None
            if row is not None:
                self.on_result(row)
                self.stats.finished += 1
                self.assign(worker)
                return
        if worker.process.sentinel in ready or not worker.process.is_alive():
            worker.process.join(timeout=1)
            code = worker.process.exitcode
            reason = (
                f"worker crashed (signal {-code})"
                if code and code < 0
                else f"worker exited with code {code}"
            )
            assert worker.episode is not None
            self.workers.remove(worker)
            self.requeued.extend(reversed(worker.group))  # the rest of its group, in order
            worker.group = []
            self.retry_or_fail(worker.episode, reason)
            self.start()

    def retry_or_fail(self, episode: EpisodeSpec, reason: str) -> None:
        """A dead worker's episode runs again (``CRASH_RETRIES`` times), then is an error row:
        a one-off crash (out of memory, a killed process) must not count as a failed pick."""
        attempts = self.attempts.get(episode.resolved_id, 0) + 1
        self.attempts[episode.resolved_id] = attempts
        if attempts <= CRASH_RETRIES:
            self.requeued.append(episode)
            self.stats.retried += 1
            return
        suffix = f" ({attempts} attempts)" if attempts > 1 else ""
        self.on_result(error_row(episode, reason + suffix))
        self.stats.finished += 1
        self.stats.crashed += 1

    def shutdown(self) -> None:
        """Stop every worker: a polite stop after a normal run, terminate after Ctrl-C."""
        for worker in self.workers:
            try:
                if self.stats.interrupted:
                    worker.process.terminate()
                else:
                    worker.conn.send(None)
            except (OSError, BrokenPipeError):
                pass
        for worker in self.workers:
            worker.process.join(timeout=5)
            if worker.process.is_alive():
                worker.process.kill()


def run_process_pool(
    episodes: list[EpisodeSpec],
    run_dir: Path,
    record: str,
    on_result: OnResult,
    workers: int,
    share: bool = True,
) -> RunStats:
    """One process per worker, one episode in flight per worker; dead workers are replaced."""
    pool = _ProcessPool(episodes, run_dir, record, on_result, share)
    stats = pool.stats
    start = time.perf_counter()
    try:
        for _ in range(max(1, min(workers, len(episodes)))):
            pool.start()
        while any(w.episode is not None for w in pool.workers):
            busy = [w for w in pool.workers if w.episode is not None]
            handles = [w.conn for w in busy] + [w.process.sentinel for w in busy]
            ready = wait(handles, timeout=pool.next_deadline())
            for worker in busy:
                if worker in pool.workers:
                    pool.collect(worker, ready)
            pool.kill_overdue()
    except KeyboardInterrupt:
        stats.interrupted = True
    finally:
        pool.shutdown()
    stats.wall_time_s = time.perf_counter() - start
    return stats


def run_ray(
    episodes: list[EpisodeSpec],
    run_dir: Path,
    record: str,
    on_result: OnResult,
    workers: int,
    address: str | None = None,
    share: bool = True,
) -> RunStats:
    """Ray actors (one scene and candidate cache each). An actor that dies mid-episode is
    restarted and its episode run again ``CRASH_RETRIES`` times (Ray's ``max_task_retries``)
    before it becomes an error row. Share groups are submitted back to back; a free actor takes
    the next episode, so a group may spread over actors (each shares what it holds). A locally
    started Ray listens on 127.0.0.1 only, without the dashboard, and a watchdog ends it if
    this process dies (``harness.runs.ray_local``; docs/reliability.md, "Network")."""
    try:
        import ray
    except ImportError as exc:  # pragma: no cover - depends on the extra
        from harness.errors import HarnessError

        raise HarnessError(
            "the ray backend needs the 'ray' extra: pip install 'pick-harness[ray]'"
        ) from exc

    with contextlib.ExitStack() as stack:
        if not ray.is_initialized():
            if address:
                try:
                    ray.init(address=address, log_to_driver=False)
                except ConnectionError as exc:  # the port answers, but no Ray head is there
                    from harness.errors import HarnessError

                    raise HarnessError(f"--address {address}: {exc}") from None
                stack.callback(ray.shutdown)
            else:  # on 127.0.0.1 only, and gone with this process (harness.runs.ray_local)
                from harness.runs.ray_local import local_ray

                stack.enter_context(local_ray(workers))
        return _run_on_ray(ray, episodes, run_dir, record, on_result, workers, share)


def _run_on_ray(
    ray: Any,
    episodes: list[EpisodeSpec],
    run_dir: Path,
    record: str,
    on_result: OnResult,
    workers: int,
    share: bool,
) -> RunStats:
    """The episodes on actors of an initialised Ray (see ``run_ray``)."""

    @ray.remote(num_cpus=1, max_restarts=-1, max_task_retries=CRASH_RETRIES)
    class EpisodeActor:
        def run(self, episode: EpisodeSpec) -> dict[str, Any]:
            return execute(episode, str(run_dir), record, share)

    stats = RunStats()
    start = time.perf_counter()
    pending = iter(shared_order(episodes) if share else episodes)
    actors = [EpisodeActor.remote() for _ in range(max(1, min(workers, len(episodes))))]
    in_flight: dict[Any, tuple[Any, EpisodeSpec]] = {}

    def submit(actor: Any) -> None:
        episode = next(pending, None)
        if episode is not None:
            in_flight[actor.run.remote(episode)] = (actor, episode)

    try:
        for actor in actors:
            submit(actor)
        while in_flight:
            done, _ = ray.wait(list(in_flight), num_returns=1)
            ref = done[0]
            actor, episode = in_flight.pop(ref)
            try:
                row = ray.get(ref)
            except Exception as exc:  # the actor died again after its retries, or a task error
                attempts = f" ({CRASH_RETRIES + 1} attempts)" if CRASH_RETRIES else ""
                row = error_row(episode, f"ray worker failed: {type(exc).__name__}{attempts}")
                stats.crashed += 1
            on_result(row)
            stats.finished += 1
            submit(actor)
    except KeyboardInterrupt:
        stats.interrupted = True
        for ref in in_flight:
            ray.cancel(ref, force=True)
    stats.wall_time_s = time.perf_counter() - start
    return stats


class Executor(Protocol):
    """Runs ``episodes`` (recordings under ``run_dir`` per the ``record`` policy), passing each
    row to ``on_result`` as it arrives; returns how the run went. With ``share`` the points that
    differ only in selection keys share candidate evaluations
    (``harness.episode.candidate_cache``)."""

    def __call__(
        self,
        episodes: list[EpisodeSpec],
        run_dir: Path,
        record: str,
        on_result: OnResult,
        share: bool = True,
    ) -> RunStats: ...


def executor_for(backend: str, workers: int, address: str | None = None) -> Executor:
    """The executor of a backend name: ``serial``, ``process`` or ``ray``."""
    if backend == "serial":
        return run_serial
    if backend == "ray":
        return functools.partial(run_ray, workers=workers, address=address)
    if backend == "process":
        return functools.partial(run_process_pool, workers=workers)
    raise ConfigError(f"unknown backend {backend!r}; use serial, process or ray")
