"""Keeping a run inside its run directory: safe file names, no symlinks, one process at a time.

A sweep runs unattended for hours, so everything it writes must land inside its run directory
whatever a task is named, a planted symlink must never redirect a write, and two processes must
never fill one run directory at once (two ``--resume`` of the same run would run every episode
twice). ``--resume`` must also refuse a run whose ``sweep.yaml`` was edited since it was created,
or it would silently mix two configurations in one table.
"""

from __future__ import annotations

import fcntl
import hashlib
import os
from collections.abc import Iterable
from pathlib import Path
from typing import IO

from harness.config import ConfigError
from harness.files import safe_file_name

__all__ = ["RunLock", "inside", "refuse_symlinks", "safe_file_name"]

LOCK_NAME = ".lock"
HASH_NAME = ".sweep.sha256"


def inside(run_dir: Path, path: Path) -> Path:
    """``path`` if it resolves inside ``run_dir``, else a ConfigError."""
    root = run_dir.resolve()
    resolved = path.resolve()
    if resolved != root and root not in resolved.parents:
        raise ConfigError(f"refusing to write outside the run directory: {path}", file=run_dir)
    return path


def refuse_symlinks(run_dir: Path, outputs: Iterable[str]) -> None:
    """A run directory whose ``outputs`` (top-level names a run writes) include a symlink is
    refused (a write would follow it)."""
    if run_dir.is_symlink():
        raise ConfigError("the run directory is a symlink; give its real path", file=run_dir)
    for name in (*outputs, LOCK_NAME, HASH_NAME):
        if (run_dir / name).is_symlink():
            raise ConfigError(
                f"{name} in the run directory is a symlink; remove it (a run never follows one)",
                file=run_dir,
            )


def sweep_hash(sweep_yaml: Path) -> str:
    return hashlib.sha256(sweep_yaml.read_bytes()).hexdigest()


def record_sweep_hash(run_dir: Path, sweep_yaml: Path) -> None:
    (run_dir / HASH_NAME).write_text(sweep_hash(sweep_yaml) + "\n", encoding="utf-8")


def check_sweep_hash(run_dir: Path, sweep_yaml: Path, force: bool) -> None:
    """``--resume`` of an edited ``sweep.yaml`` is refused unless ``force``."""
    stored = run_dir / HASH_NAME
    if force or not stored.is_file():
        return
    if stored.read_text(encoding="utf-8").strip() != sweep_hash(sweep_yaml):
        raise ConfigError(
            "sweep.yaml changed since the run was created; resuming would mix two "
            "configurations in one table (start a new run, or pass --force to resume anyway)",
            file=sweep_yaml,
        )


class RunLock:
    """An exclusive lock on a run directory, held while a process fills it."""

    def __init__(self, run_dir: Path) -> None:
        self.path = run_dir / LOCK_NAME
        self._handle: IO[str] | None = None

    def acquire(self) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        handle = open(self.path, "a+", encoding="utf-8")  # noqa: SIM115 (held until release)
        try:
            fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.seek(0)
            holder = handle.read().strip() or "another process"
            handle.close()
            raise ConfigError(
                f"the run directory is in use by {holder}; wait for it to finish",
                file=self.path.parent,
            ) from None
        handle.seek(0)
        handle.truncate()
        handle.write(f"harness pid {os.getpid()}\n")
        handle.flush()
        self._handle = handle

    def release(self) -> None:
        if self._handle is not None:
            fcntl.flock(self._handle.fileno(), fcntl.LOCK_UN)
            self._handle.close()
            self._handle = None

    def __enter__(self) -> RunLock:
        self.acquire()
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()
