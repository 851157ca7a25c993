"""THE write rule of the harness: every file a command writes goes through here.

One rule for run directories, tune directories and user-named outputs (``--record``,
``--video``, ``--plot``, ``tune --write``):

- a path that exists and is not a regular file (a FIFO, ``/dev/full``, a socket, a directory
  where a file is expected) is refused with one line naming it: writing would block, or, by
  renaming over it, replace a device;
- a symlink at the path, or at any folder between a run/tune directory (``root``) and the path,
  is refused and never followed (a planted ``tune -> /elsewhere`` would redirect every write);
- the data go to a fresh temp file beside the target (``O_CREAT | O_EXCL | O_NOFOLLOW``: it
  cannot be a link or someone else's file), are fsynced, and the temp file is renamed over the
  target (a rename replaces a directory entry, it never writes through one);
- a write that fails (ENOSPC, EROFS, EIO) raises ``OSError`` whose ``filename`` is the target,
  so the CLI prints ``error: PATH: reason``; the temp file is removed.

Dependencies: the standard library and ``harness.errors`` only (``harness.files`` builds on it).
"""

from __future__ import annotations

import errno
import os
import secrets
import stat
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, BinaryIO

from harness.errors import HarnessError

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


def _process_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


# Written files get the usual permissions (a plain open() would give them).
FILE_MODE = 0o666 & ~_process_umask()


class OutputFileError(HarnessError):
    """An output path the harness does not write: a special file, or a symlink."""


def kind_of(mode: int) -> str:
    """``a FIFO`` / ``a directory`` / ``a device`` / ``a socket`` / ``not a regular file``."""
    if stat.S_ISFIFO(mode):
        return "a FIFO"
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def check_target(path: Path) -> None:
    """Refuse ``path`` unless it is absent or a regular file (``lstat``: nothing followed)."""
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        return
    if stat.S_ISLNK(mode):
        raise OutputFileError(f"{path}: is a symlink; a harness command never writes through one")
    if not stat.S_ISREG(mode):
        raise OutputFileError(
            f"{path}: is {kind_of(mode)}; a harness command replaces only regular files"
        )


def output_dir(folder: Path, root: Path | None = None) -> Path:
    """``folder``, created if missing; with ``root`` (a run or tune directory), ``root`` and
    every folder from it down to ``folder`` must be a real directory, never a symlink."""
    folder = Path(folder)
    if root is None:
        folder.mkdir(parents=True, exist_ok=True)
        if not folder.is_dir():
            raise OutputFileError(f"{folder}: is not a directory")
        return folder
    root = Path(root)
    parts = folder.relative_to(root).parts
    current = root
    for part in ("", *parts):
        current = current / part if part else current
        try:
            mode = os.lstat(current).st_mode
        except FileNotFoundError:
            current.mkdir(parents=current == root)
            continue
        if stat.S_ISLNK(mode):
            where = "give its real path" if current == root else f"inside {root}; remove it"
            raise OutputFileError(
                f"{current}: is a symlink ({where}: a harness command never writes through one)"
            )
        if not stat.S_ISDIR(mode):
            raise OutputFileError(f"{current}: is {kind_of(mode)}, where a folder belongs")
    return folder


def named_error(exc: OSError, path: Path) -> OSError:
    """``exc`` with ``path`` as its file name (one line ``PATH: reason`` at the CLI)."""
    named = OSError(exc.errno, exc.strerror or str(exc), str(path))
    named.__cause__ = exc
    return named


def _temp_path(path: Path, suffix: str) -> tuple[Path, int]:
    """A fresh temp file beside ``path`` (created here: never a link, never someone's file)."""
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC
    for _ in range(100):
        tmp = path.with_name(f".{path.name}.{secrets.token_hex(4)}.tmp{suffix}")
        try:
            return tmp, os.open(tmp, flags, FILE_MODE)
        except FileExistsError:
            continue
    raise OSError(errno.EEXIST, "no free temp file name", str(path))


def _replace(tmp: Path, path: Path) -> None:
    check_target(path)  # again, just before: a FIFO planted while the data were written
    os.replace(tmp, path)


def write_file(path: str | Path, data: bytes | str, root: Path | None = None) -> Path:
    """Write ``data`` to ``path`` whole (temp + fsync + rename) under the rule above."""
    path = Path(path)
    payload = data.encode("utf-8") if isinstance(data, str) else data
    tmp, fd = _start(path, "", root)

    def write() -> None:
        with os.fdopen(fd, "wb") as handle:
            write_whole(handle, payload, path)

    return _commit(tmp, path, write)


def write_whole(handle: BinaryIO, payload: bytes, path: Path) -> None:
    """``payload`` into the open temp file of ``path``, flushed and synced to the disk."""
    handle.write(payload)
    handle.flush()
    os.fsync(handle.fileno())


def write_through(
    path: str | Path, write: Callable[[Path], object], root: Path | None = None
) -> Path:
    """``write(tmp)`` for writers that take a file name (``savefig``, ``to_csv``, ``np.save``,
    ffmpeg), then the rename under the rule above. ``tmp`` keeps ``path``'s suffix (writers
    pick their format from it) and is a regular file this process created."""
    path = Path(path)
    tmp, fd = _start(path, path.suffix, root)
    os.close(fd)
    return _commit(tmp, path, lambda: write(tmp))


def _start(path: Path, suffix: str, root: Path | None) -> tuple[Path, int]:
    """Check ``path`` under the rule, make its folder, and create its temp file (an open fd)."""
    check_target(path)
    output_dir(path.parent, root)
    try:
        return _temp_path(path, suffix)
    except OSError as exc:
        raise named_error(exc, path) from None


def _commit(tmp: Path, path: Path, write: Callable[[], object]) -> Path:
    """``write()`` the temp file, then rename it over ``path``; on any failure the temp file
    is removed, and an ``OSError`` is raised naming ``path``."""
    try:
        write()
        _replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise named_error(exc, path) from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def open_append(path: str | Path, *, read: bool = False) -> int:
    """A descriptor appending to ``path`` (created if missing), for files written line by line
    (``episodes.jsonl``, the lock file): never through a symlink (``O_NOFOLLOW``), never
    blocking on a FIFO (``O_NONBLOCK``, then ``fstat``: anything but a regular file refused)."""
    path = Path(path)
    access = os.O_RDWR if read else os.O_WRONLY
    flags = access | os.O_APPEND | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC
    try:
        fd = os.open(path, flags, FILE_MODE)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise OutputFileError(
                f"{path}: is a symlink; a harness command never writes through one"
            ) from None
        if exc.errno in (errno.ENXIO, errno.EISDIR):  # a FIFO without reader, a folder
            check_target(path)
        raise named_error(exc, path) from None
    mode = os.fstat(fd).st_mode
    if not stat.S_ISREG(mode):
        os.close(fd)
        raise OutputFileError(
            f"{path}: is {kind_of(mode)}; a harness command appends only to regular files"
        )
    os.set_blocking(fd, True)
    return fd


def check_outputs(root: Path, files: tuple[str, ...] = (), folders: tuple[str, ...] = ()) -> None:
    """Refuse, before any work, a ``root`` (a run or tune directory) that is a symlink, any of
    its output ``files`` that is a symlink or not a regular file, and any output folder (and
    anything inside one) that is a symlink or a special file: a long command must not run for
    minutes and then be refused at its first write."""
    root = Path(root)
    if root.is_symlink():
        raise OutputFileError(f"{root}: is a symlink; give its real path")
    for name in files:
        check_target(root / name)
    for name in folders:
        folder = root / name
        if folder.is_symlink() or (folder.exists() and not folder.is_dir()):
            output_dir(folder, root)  # raises naming the link or the file
        if not folder.is_dir():
            continue
        with os.scandir(folder) as entries:
            for entry in entries:
                if not entry.is_dir(follow_symlinks=False):
                    check_target(Path(entry.path))


def write_npy(path: str | Path, array: ArrayLike, root: Path | None = None) -> Path:
    """``np.save`` of ``array`` to exactly ``path`` under the rule above (through a handle:
    ``np.save`` given a name without ``.npy`` would write to another file)."""
    import numpy as np

    def save(tmp: Path) -> None:
        with open(tmp, "wb") as handle:
            np.save(handle, array)

    return write_through(path, save, root)
