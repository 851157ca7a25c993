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
from harness.files import planted_link, safe_file_name
from harness.writes import open_append, write_file

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
    """A run directory whose ``outputs`` (top-level names a run writes, and the files inside
    those that are folders) include a symlink is refused (a write would follow it)."""
    link = planted_link(run_dir, (*outputs, LOCK_NAME, HASH_NAME))
    if link == run_dir:
        raise ConfigError("the run directory is a symlink; give its real path", file=run_dir)
    if link is not None:
        raise ConfigError(
            f"{link.relative_to(run_dir)} in the run directory is a symlink; remove it (a run "
            "never follows one)",
            file=run_dir,
        )


HEADER_PREFIX = "# config_sha256: "


def with_hash_header(body: str) -> str:
    """``sweep.yaml`` text: a comment line with the sha256 of the body, then the body. The hash
    travels with the file (``cp run/*`` drops ``.sweep.sha256``), so an edit is detectable."""
    return f"{HEADER_PREFIX}{body_hash(body)}\n{body}"


def body_hash(body: str) -> str:
    return hashlib.sha256(body.encode("utf-8")).hexdigest()


def split_header(text: str) -> tuple[str | None, str]:
    """(the hash the header line records, or None, the body)."""
    if text.startswith(HEADER_PREFIX):
        first, _, body = text.partition("\n")
        return first.removeprefix(HEADER_PREFIX).strip(), body
    return None, text


def sweep_hash(sweep_yaml: Path) -> str:
    """The configuration hash of a run's ``sweep.yaml``: its body's sha256 (header excluded)."""
    return body_hash(split_header(sweep_yaml.read_text(encoding="utf-8"))[1])


def record_sweep_hash(run_dir: Path, sweep_yaml: Path) -> None:
    write_file(run_dir / HASH_NAME, sweep_hash(sweep_yaml) + "\n", root=run_dir)


EDITED = (
    "resuming would mix two configurations in one table (start a new run, or pass --force to "
    "resume anyway)"
)


def check_sweep_hash(
    run_dir: Path, sweep_yaml: Path, force: bool, row_hashes: Iterable[str] = ()
) -> str:
    """The configuration hash of ``sweep.yaml``; ``--resume`` of an edited one is refused
    unless ``force``. Three witnesses, any one suffices: the header line of ``sweep.yaml``, the
    ``.sweep.sha256`` file and the ``config_sha256`` of every stored row."""
    header, body = split_header(sweep_yaml.read_text(encoding="utf-8"))
    current = body_hash(body)
    if force:
        return current
    if header is not None and header != current:
        raise ConfigError(
            f"sweep.yaml changed since the run was created (its config_sha256 header line "
            f"differs from its body); {EDITED}",
            file=sweep_yaml,
        )
    stored = run_dir / HASH_NAME
    if stored.is_file() and stored.read_text(encoding="utf-8").strip() != current:
        raise ConfigError(
            f"sweep.yaml changed since the run was created; {EDITED}", file=sweep_yaml
        )
    others = {h for h in row_hashes if h and h != current}
    if others:
        raise ConfigError(
            f"sweep.yaml changed since the run was created: stored rows have config_sha256 "
            f"{sorted(others)[0][:12]}..., sweep.yaml now {current[:12]}...; {EDITED}",
            file=sweep_yaml,
        )
    return current


class RunLock:
    """An exclusive lock on a run directory, held while a process fills it."""

    def __init__(self, run_dir: Path) -> None:
        self.path = run_dir / LOCK_NAME
        self._handle: IO[str] | None = None

    def acquire(self) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        handle = os.fdopen(open_append(self.path, read=True), "a+", encoding="utf-8")
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
