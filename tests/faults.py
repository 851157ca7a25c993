"""Faults injected into the harness's own workers, for the crash-recovery tests (the product
holds no switch for them): a real segfault (``ctypes.string_at(0)``) or a hang with SIGALRM
blocked, as a crashing or stuck C extension would, in the worker that runs a named episode;
and a write that fails half-way with ENOSPC, as on a full disk.

``install`` puts a ``Faults`` in place of the episode function of ``harness.runs.executors``
(the serial executor and the Ray actors call it; a test on Ray also registers this module to
be pickled by value, since Ray's workers do not import from ``tests/``), and wraps the process
pool's worker main so that each worker spawned afterwards installs it in itself first (spawn
pickles the wrapper by reference: ``tests/`` is on the child's ``sys.path``, which spawn passes
on). ``disk_full`` replaces the one write call of ``harness.writes.write_file``.
"""

from __future__ import annotations

import errno
import functools
import os
import signal
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from harness import writes
from harness.runs import executors, worker


@dataclass(frozen=True)
class Faults:
    """Which episodes' workers fail, and how: ``segfault`` dies by SIGSEGV (with ``once_dir``
    only on each episode's first attempt, a marker file in that folder saying it happened),
    ``hang`` never returns with SIGALRM blocked."""

    segfault: frozenset[str] = frozenset()
    once_dir: str | None = None
    hang: frozenset[str] = frozenset()

    def __call__(
        self, episode: Any, run_dir: str, record: str, share: bool = True
    ) -> dict[str, Any]:
        """The worker's episode function with the fault struck first."""
        self.strike(episode.resolved_id)
        return worker.execute(episode, run_dir, record, share)

    def strike(self, episode_id: str) -> None:
        if episode_id in self.hang:
            signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGALRM})
            while True:
                time.sleep(3600)
        if episode_id not in self.segfault:
            return
        if self.once_dir is not None:  # crash only on the first attempt of each episode
            marker = Path(self.once_dir) / episode_id
            if marker.exists():
                return
            marker.touch()
        import ctypes

        ctypes.string_at(0)  # dereference NULL: SIGSEGV


def faulty_worker_main(faults: Faults, *args: Any) -> None:
    """A process-pool worker (in the spawned child) that runs its episodes through ``faults``."""
    executors.execute = faults
    executors._worker_main(*args)


def install(
    monkeypatch: pytest.MonkeyPatch,
    segfault: tuple[str, ...] = (),
    once_dir: Path | None = None,
    hang: tuple[str, ...] = (),
) -> Faults:
    """Strike ``Faults`` in every executor started after this (undone with ``monkeypatch``)."""
    faults = Faults(
        frozenset(segfault), None if once_dir is None else str(once_dir), frozenset(hang)
    )
    monkeypatch.setattr(executors, "execute", faults)
    monkeypatch.setattr(executors, "_worker_main", functools.partial(faulty_worker_main, faults))
    return faults


def disk_full(monkeypatch: pytest.MonkeyPatch, name_part: str) -> None:
    """Every ``write_file`` (in this process) to a file whose name contains ``name_part``
    writes half its data, then fails with ENOSPC."""
    real = writes.write_whole

    def failing(handle: Any, payload: bytes, path: Path) -> None:
        if name_part not in path.name:
            real(handle, payload, path)
            return
        handle.write(payload[: len(payload) // 2])
        handle.flush()
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))

    monkeypatch.setattr(writes, "write_whole", failing)
