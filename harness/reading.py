"""THE read rule: how a command reads any file it is given or that a given file pulls in.

Every input file (a mesh and what it includes: OBJ ``mtllib``, MTL ``map_Kd`` textures, glTF
buffers, USD sublayers and references; a run's parquet, CSV and JSON; a grasp ``.npy``) is

- a **regular file**, checked on an open descriptor before anything reads it: a FIFO would wait
  forever for a writer, a device (``/dev/zero``) never ends, a directory is no file;
- **size-capped**, with the cap held while reading (a file that grows stops at the cap);
- reached **without loops**: a symlink loop is refused (``resolve`` raised ``RuntimeError``);
- **parsed into an input error**: what a parser raises on garbage (``ArrowInvalid``,
  ``BadZipFile``, ``JSONDecodeError``, pandas' ``ParserError``) becomes one
  ``InputFileError`` naming the file, so the CLI prints one line and exits 2.

The descriptor-level primitives (``open_regular``, ``check_regular``, ``read_capped``) are in
``harness.files``; this module is the one front door readers use.
"""

from __future__ import annotations

import errno
import json
import math
import zipfile
from pathlib import Path
from typing import Any

from harness.errors import InputFileError
from harness.files import MAX_CONFIG_BYTES, RefusedFileError, check_regular, read_capped

__all__ = [
    "MAX_CONFIG_BYTES",
    "MAX_JSON_BYTES",
    "MAX_TABLE_BYTES",
    "RefusedFileError",
    "check_input",
    "check_regular",
    "load_npy",
    "read_capped",
    "read_csv",
    "read_json",
    "read_parquet",
    "resolve_input",
]

# A run's episode table: ~1 kB a row as CSV, so 1 GiB is ~10^6 episodes, far past a sweep's
# default cap (harness.runs.limits). Chosen, no public source.
MAX_TABLE_BYTES = 1 << 30
# The JSON files the harness reads back (tune.json, videos.json) are a few kB. Chosen.
MAX_JSON_BYTES = 16 * 1024 * 1024


def resolve_input(path: str | Path, what: str = "file") -> Path:
    """``path`` made absolute with its links followed; ``InputFileError`` on a symlink loop
    (``Path.resolve`` raises ``RuntimeError`` for one, ``os.open`` ``ELOOP``)."""
    try:
        return Path(path).resolve()
    except RuntimeError:
        raise InputFileError(path, f"{what} is a symlink loop") from None
    except OSError as exc:
        raise InputFileError(path, f"cannot resolve {what}: {_reason(exc)}") from None


def check_input(path: str | Path, max_bytes: int | None, what: str = "file") -> int:
    """The size of the input file ``path``; ``InputFileError`` naming it when it is missing,
    not a regular file, over ``max_bytes``, a symlink loop or unreadable."""
    try:
        return check_regular(path, max_bytes)
    except OSError as exc:
        raise _input_error(path, what, exc) from None


def _input_error(path: str | Path, what: str, exc: OSError) -> InputFileError:
    """The one-line input error for ``exc`` met opening ``path`` (missing, refused, other)."""
    if isinstance(exc, FileNotFoundError):
        return InputFileError(path, f"{what} not found")
    if isinstance(exc, RefusedFileError):
        return InputFileError(path, f"{what} {exc}")
    return InputFileError(path, f"cannot read {what}: {_reason(exc)}")


def _reason(exc: OSError) -> str:
    if exc.errno == errno.ELOOP:
        return "a symlink loop"
    return (exc.strerror or str(exc)).lower()


def read_json(path: str | Path, max_bytes: int = MAX_JSON_BYTES, what: str = "JSON file") -> Any:
    """The parsed JSON of ``path`` (regular, capped); garbage is an ``InputFileError``."""
    try:
        data = read_capped(path, max_bytes)
    except OSError as exc:
        raise _input_error(path, what, exc) from None
    try:
        return json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
        raise InputFileError(path, f"{what} is not valid JSON: {_first_line(exc)}") from None


def read_parquet(path: str | Path, what: str = "parquet table") -> Any:
    """``pandas.read_parquet`` of a regular, capped file; a file pyarrow cannot read (no
    parquet footer, a torn write) is an ``InputFileError``, not ``ArrowInvalid``."""
    import pandas as pd

    check_input(path, MAX_TABLE_BYTES, what)
    try:
        return pd.read_parquet(path)
    except MemoryError:
        raise InputFileError(path, f"{what} does not fit in memory") from None
    except Exception as exc:  # pyarrow.lib.ArrowInvalid, OSError, ValueError, ...
        raise InputFileError(path, f"cannot read {what}: {_first_line(exc)}") from None


def read_csv(path: str | Path, what: str = "CSV table", **options: Any) -> Any:
    """``pandas.read_csv`` of a regular, capped file; garbage is an ``InputFileError``."""
    import pandas as pd

    check_input(path, MAX_TABLE_BYTES, what)
    try:
        return pd.read_csv(path, **options)
    except (OSError, ValueError, UnicodeDecodeError, pd.errors.ParserError) as exc:
        raise InputFileError(path, f"cannot read {what}: {_first_line(exc)}") from None


def load_npy(path: str | Path, max_bytes: int, what: str = "array file", mmap: bool = False) -> Any:
    """One array from a ``.npy`` file (no pickles), its header checked against the file's size
    before numpy allocates what it claims; an ``.npz`` archive is returned open (the caller
    decides), a corrupt one is an ``InputFileError``. ``mmap`` maps the array instead of
    reading it (a row count)."""
    import numpy as np

    path = Path(path)
    size = check_input(path, max_bytes, what)
    try:
        _check_npy_header(path, size)
        return np.load(path, allow_pickle=False, mmap_mode="r" if mmap else None)
    except (
        OSError,
        ValueError,
        EOFError,
        MemoryError,
        zipfile.BadZipFile,
        KeyError,  # a zip without the entries numpy expects
    ) as exc:
        raise InputFileError(path, f"cannot read as a .npy array: {_first_line(exc)}") from None


def _check_npy_header(path: Path, size: int) -> None:
    """``ValueError`` when a ``.npy`` header claims more data than the file holds."""
    import numpy as np

    with open(path, "rb") as handle:
        if handle.read(6) != b"\x93NUMPY":
            return
        handle.seek(0)
        version = np.lib.format.read_magic(handle)
        if version == (1, 0):
            shape, _, dtype = np.lib.format.read_array_header_1_0(handle)
        else:
            shape, _, dtype = np.lib.format.read_array_header_2_0(handle)
        if dtype.hasobject:  # pickled objects: np.load refuses them (allow_pickle=False)
            return
        claimed = math.prod(shape) * dtype.itemsize
        if claimed > size - handle.tell():
            raise ValueError(
                f"its header claims shape {shape} ({claimed:,} bytes) but the file holds "
                f"{size - handle.tell():,} bytes of data"
            )


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return (text.splitlines()[0] if text else type(exc).__name__)[:300]
