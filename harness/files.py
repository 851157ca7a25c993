"""Writing files that are whole or absent: temp file + fsync + rename, under a bounded wait.

A reader (a report viewer, ``--resume``, a later run) must never see half a file, and a full or
hung disk must not hang an unattended run. ``write_atomic`` writes to a hidden temp file beside
the target, fsyncs it and renames it over the target; on any failure the temp file is removed and
the target is left as it was. ``bounded`` runs a blocking call on a helper thread and gives up
after a timeout (the thread is abandoned; the caller goes on). ``is_disk_full`` tells a full
disk (ENOSPC, EDQUOT) from other I/O errors, so a run can stop on it with one line.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import os
import re
import stat
import threading
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import TypeVar

from harness.errors import HarnessError
from harness.writes import FILE_MODE, OutputFileError, kind_of, write_file

T = TypeVar("T")

__all__ = ["FILE_MODE", "OutputFileError", "write_atomic"]

# A generous bound for one file write (a recording is a few MB): a healthy disk takes well under
# a second, so only a hung file system reaches it.
WRITE_TIMEOUT_S = 60.0
DISK_FULL_ERRNOS = (errno.ENOSPC, errno.EDQUOT)


_UNSAFE = re.compile(r"[^A-Za-z0-9._-]+")
MAX_NAME = 120


def safe_file_name(name: str, suffix: str = "") -> str:
    """THE way a name from input (a task, object, robot or episode name) becomes a file name.

    The result cannot leave its folder (no ``/``, ``..``, leading dot or control characters);
    a short hash of the original keeps distinct names distinct. Every output path built from a
    name goes through here (``tests/test_adversarial.py`` greps the package for others).
    """
    slug = _UNSAFE.sub("_", name).strip("._") or "unnamed"
    if slug != name or len(slug) > MAX_NAME:
        digest = hashlib.sha256(name.encode("utf-8")).hexdigest()[:10]
        slug = f"{slug[:MAX_NAME]}-{digest}"
    return slug + suffix


def safe_child(folder: Path, *parts: str, suffix: str = "") -> Path:
    """``folder / <safe name of the parts joined by '_'><suffix>``: a file inside ``folder``."""
    return folder / safe_file_name("_".join(parts), suffix)


# Task, sweep, robot and object YAML files are a few kB; a 60 MB YAML took minutes to parse.
MAX_CONFIG_BYTES = 4 * 1024 * 1024


class RefusedFileError(ValueError):
    """An input file that is not read: not a regular file, or over its byte cap (``too_large``)."""

    def __init__(self, message: str, too_large: bool = False) -> None:
        super().__init__(message)
        self.too_large = too_large


# Paths read by ``open_regular`` while a ``recording_reads`` block is open (the inputs of a
# run: meshes, USD layers, grasp files, robot and object YAML), for the run's input manifest.
_READ_LOGS: list[set[str]] = []


@contextlib.contextmanager
def recording_reads() -> Iterator[set[str]]:
    """The resolved paths of every file read through ``open_regular`` (``check_regular``,
    ``read_capped``) inside the block."""
    log: set[str] = set()
    _READ_LOGS.append(log)
    try:
        yield log
    finally:
        _READ_LOGS.remove(log)


def open_regular(path: str | Path) -> int:
    """A read-only descriptor of ``path`` if it is a regular file, else ``RefusedFileError``.

    Opened non-blocking, so a FIFO (``mkfifo t.yaml``) does not wait for a writer, then checked
    with ``fstat`` on the descriptor itself: a FIFO, a device (``/dev/zero`` reports
    ``st_size`` 0, so a size check alone passes it and the read never ends), a socket or a
    directory is refused. Symlinks to regular files are read (a task may link its mesh).
    """
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise RefusedFileError(f"is {kind_of(mode)}, not a regular file")
        os.set_blocking(fd, True)
        for log in _READ_LOGS:
            log.add(str(Path(path).resolve()))
        return fd
    except BaseException:
        os.close(fd)
        raise


def check_regular(path: str | Path, max_bytes: int | None = None) -> int:
    """``path``'s size if it is a regular file within ``max_bytes``; else ``RefusedFileError``.

    For readers that open the file themselves (USD, trimesh, numpy): check, then hand over.
    """
    fd = open_regular(path)
    try:
        size = os.fstat(fd).st_size
    finally:
        os.close(fd)
    if max_bytes is not None and size > max_bytes:
        raise RefusedFileError(f"is {size:,} bytes, above the limit of {max_bytes:,}", True)
    return size


def read_capped(path: str | Path, max_bytes: int) -> bytes:
    """The bytes of the regular file ``path``, never more than ``max_bytes`` read.

    The cap holds while reading too (a file that grows, or lies about its size, stops at
    ``max_bytes + 1`` bytes and is refused), so no input can exhaust memory or time.
    """
    fd = open_regular(path)
    try:
        chunks: list[bytes] = []
        total = 0
        while total <= max_bytes:
            chunk = os.read(fd, min(1 << 20, max_bytes + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
    finally:
        os.close(fd)
    if total > max_bytes:
        raise RefusedFileError(f"is larger than the limit of {max_bytes:,} bytes", True)
    return b"".join(chunks)


class PlantedLinkError(HarnessError):
    """A symlink where a run writes: refused, never followed (it could point anywhere)."""


def planted_link(root: Path, names: Iterable[str]) -> Path | None:
    """The first symlink among ``root`` itself, ``root/<name>`` for each name, and the entries
    of each such name that is a folder (``plots/*.png``, ``episodes/*.rrd``, ...); None if none.

    THE symlink check of the harness: ``lstat`` only (nothing is followed, nothing opened).
    """
    if root.is_symlink():
        return root
    for name in names:
        path = root / name
        if path.is_symlink():
            return path
        if path.is_dir():
            with os.scandir(path) as entries:
                for entry in entries:
                    if entry.is_symlink():
                        return Path(entry.path)
    return None


def refuse_planted_links(root: Path, names: Iterable[str]) -> None:
    """``PlantedLinkError`` naming the first symlink ``planted_link`` finds."""
    link = planted_link(root, names)
    if link is not None:
        where = (
            "the run directory is a symlink; give its real path"
            if link == root
            else (
                f"{link.relative_to(root)} in the run directory is a symlink; remove it (a run "
                "never follows one)"
            )
        )
        raise PlantedLinkError(f"{root}: {where}")


def is_disk_full(exc: BaseException) -> bool:
    """True for "no space left on device" and "disk quota exceeded"."""
    return isinstance(exc, OSError) and exc.errno in DISK_FULL_ERRNOS


def bounded(call: Callable[[], T], timeout_s: float, what: str) -> T:
    """``call()``, or ``TimeoutError`` naming ``what`` if it has not returned in ``timeout_s``."""
    outcome: dict[str, object] = {}

    def target() -> None:
        try:
            outcome["value"] = call()
        except BaseException as exc:  # handed to the caller's thread
            outcome["error"] = exc

    thread = threading.Thread(target=target, name=f"bounded {what}", daemon=True)
    thread.start()
    thread.join(timeout_s)
    if thread.is_alive():
        raise TimeoutError(f"{what} did not finish within {timeout_s:g} s")
    if "error" in outcome:
        raise outcome["error"]  # type: ignore[misc]
    return outcome["value"]  # type: ignore[return-value]


def write_atomic(
    path: str | Path,
    data: bytes | str,
    timeout_s: float = WRITE_TIMEOUT_S,
    root: Path | None = None,
) -> Path:
    """Write ``data`` to ``path`` whole within ``timeout_s``, under the write rule of
    ``harness.writes`` (special files and symlinks refused; ``root``: no link below it).

    Raises ``OSError`` naming ``path`` (``is_disk_full`` tells ENOSPC), ``OutputFileError`` or
    ``TimeoutError``; either way ``path`` is unchanged and no temp file is left behind (a
    timed-out write removes its temp file when it ends).
    """
    path = Path(path)
    bounded(lambda: write_file(path, data, root), timeout_s, f"writing {path}")
    return path
