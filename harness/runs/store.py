"""The append-only, crash-safe, resumable episode store and the typed episode table.

One episode = one flat row, with the columns of ``harness.row.SCHEMA`` (derived from
``EpisodeRow``: name -> dtype, null value, description); ``run_episode`` produces such rows,
sweeps and ``harness run`` append them to ``<run_dir>/episodes.jsonl`` through ``ResultStore``,
and reports read them back as a typed ``pandas.DataFrame`` (the CSV and Parquet exports are that
frame). Besides the fixed columns a row carries one ``param.<dotted key>`` column per swept axis
(dynamic, typed by inference).

The store is append-only JSON lines: each ``append`` writes one line and hands it to the
operating system at once, so a crash of the writing process loses at most the line being
written. The file is fsynced at most every ``SYNC_EVERY_S`` seconds and by ``sync`` (at the end
of a run): a power loss or an operating-system crash loses at most that last second's rows, which
a resumed run runs again. (An fsync per row cost ~5 ms of the parent's time per row, as much as
a shared evaluation of a dense grid: docs/performance.md, "End to end".) A torn line is skipped
on read (and a resumed run starts on a fresh line), an episode written twice (a resumed or
retried episode) keeps its last row.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import time
from collections.abc import Hashable, Iterator
from pathlib import Path
from typing import Any, cast

import numpy as np
import pandas as pd

from harness.errors import HarnessError
from harness.reading import read_csv, read_parquet
from harness.row import SCHEMA, Column, param_columns
from harness.writes import named_error, open_append, write_through

JSONL_NAME = "episodes.jsonl"
CSV_NAME = "episodes.csv"
PARQUET_NAME = "episodes.parquet"
SYNC_EVERY_S = 1.0  # the longest a written row waits for its fsync (then ``sync`` at the end)
# The last typed frame read from an ``episodes.jsonl``, by path, with the digest of the file's
# bytes and its skipped lines: a sweep exports its store and then reports it from the same rows,
# and parsing them again was ~0.15 s of a 1026-row grid's command. One entry; callers get a copy.
_LAST_LOAD: dict[Path, tuple[bytes, pd.DataFrame, list[int]]] = {}


# --------------------------------------------------------------------------------------------
# Typing


def _to_bool(value: Any) -> bool:
    if isinstance(value, str):
        return value.strip().lower() in ("true", "1", "yes")
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return False
    return bool(value)


def _is_null(value: Any) -> bool:
    return value is None or (isinstance(value, float) and math.isnan(value))


def typed_frame(rows: list[dict[str, Any]] | pd.DataFrame) -> pd.DataFrame:
    """A DataFrame in schema order and types; missing cells get the column's null value.

    Columns: the schema's, then ``param.*`` (in first-seen order), then any other columns found
    (kept, types inferred).
    """
    frame = pd.DataFrame(rows) if not isinstance(rows, pd.DataFrame) else rows.copy()
    params = param_columns(frame.columns)
    extras = [c for c in frame.columns if c not in SCHEMA and c not in params]
    out: dict[str, pd.Series] = {}
    index = frame.index
    for name, column in SCHEMA.items():
        values = (
            _series(frame, name) if name in frame.columns else pd.Series([None] * len(frame), index)
        )
        try:
            out[name] = _typed(values, column)
        except (ValueError, TypeError) as exc:
            raise ValueError(f"column {name!r} ({column.dtype}): {exc}") from None
    for name in params:
        out[name] = _param_series(_series(frame, name))
    for name in extras:
        out[name] = _series(frame, name)
    return pd.DataFrame(out, index=index).reset_index(drop=True)


def _series(frame: pd.DataFrame, name: str) -> pd.Series:
    """``frame[name]``, typed as the column it is (the pandas stubs allow a sub-frame)."""
    return cast(pd.Series, frame[name])


def _typed(values: pd.Series, column: Column) -> pd.Series:
    null = column.null_value
    if column.dtype == "str":
        cleaned = values.astype("object").where(values.notna(), null)
        return cleaned.map(str).astype("str")
    if column.dtype == "bool":
        return values.astype("object").map(_to_bool).astype("bool")
    blank = values.astype("object").map(lambda v: isinstance(v, str) and not v.strip())
    if column.dtype == "int":
        # Not through float64: 63-bit episode seeds must survive exactly.
        cells = values.astype("object").mask(blank | values.isna(), null)
        return pd.Series([_to_int(v) for v in cells], index=values.index, dtype="int64")
    numbers = cast(
        pd.Series, pd.to_numeric(values.astype("object").mask(blank, None), errors="raise")
    )
    return numbers.astype("float64")


def _to_int(value: Any) -> int:
    if isinstance(value, str):
        value = value.strip()
        return int(value) if value.lstrip("-").isdigit() else round(float(value))
    if isinstance(value, float):
        return round(value)
    return int(value)


def _param_series(values: pd.Series) -> pd.Series:
    """A swept-parameter column: numeric when every value is a number, else strings.

    Non-scalar values (lists such as ``["downward", 140]``) are written as JSON by the sweep;
    booleans stay booleans.
    """
    items = values.tolist()
    present = [v for v in items if not _is_null(v)]
    if present and all(isinstance(v, (bool, np.bool_)) for v in present):
        return pd.Series(items, index=values.index, dtype="object")
    numeric = cast(pd.Series, pd.to_numeric(values, errors="coerce"))
    if present and all(
        not isinstance(v, (bool, np.bool_)) and not _is_null(n)
        for v, n in zip(items, numeric.tolist(), strict=True)
        if not _is_null(v)
    ):
        return numeric.astype("float64")
    return pd.Series(
        ["" if _is_null(v) else (v if isinstance(v, str) else json.dumps(v)) for v in items],
        index=values.index,
        dtype="str",
    )


# --------------------------------------------------------------------------------------------
# The store


def json_default(value: Any) -> Any:
    """A row value JSON cannot take as it is (numpy scalars and arrays, paths), as JSON takes it:
    how the store writes ``episodes.jsonl``."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    return str(value)


class ResultStore:
    """Append-only episode rows of one run directory (``episodes.jsonl``).

    ``append`` is crash-safe (one line per row, written through to the operating system; fsynced
    at most every ``SYNC_EVERY_S`` and by ``sync``); ``completed_ids`` tells a
    resumed sweep what is already done; ``load`` returns the typed DataFrame (last row per
    episode id wins); ``export`` writes ``episodes.csv`` and ``episodes.parquet``. A run
    directory without ``episodes.jsonl`` (e.g. only an exported or hand-made ``episodes.csv``)
    is read from ``episodes.parquet`` or ``episodes.csv`` instead.
    """

    def __init__(self, run_dir: str | Path) -> None:
        self.run_dir = Path(run_dir)
        self.path = self.run_dir / JSONL_NAME
        self.skipped_lines: list[int] = []  # line numbers of unreadable lines, last read
        self._checked_tail = False
        self._synced_at = time.monotonic()
        self._unsynced = False

    # -- writing ------------------------------------------------------------------------------

    def append(self, row: dict[str, Any]) -> None:
        """Write one row as a JSON line (flushed: a crash of this process cannot lose it);
        force the file to disk when the last fsync is ``SYNC_EVERY_S`` old."""
        if not row.get("episode_id"):
            raise ValueError("an episode row needs a non-empty episode_id")
        line = json.dumps(row, default=json_default, allow_nan=True)
        self.run_dir.mkdir(parents=True, exist_ok=True)
        prefix = "" if self._checked_tail else self._separator()
        self._checked_tail = True
        try:
            with os.fdopen(open_append(self.path), "a", encoding="utf-8") as handle:
                handle.write(prefix + line + "\n")
                handle.flush()
                self._unsynced = True
                if time.monotonic() - self._synced_at >= SYNC_EVERY_S:
                    self._fsync(handle.fileno())
        except OSError as exc:  # a full disk: the line names episodes.jsonl
            raise named_error(exc, self.path) from None

    def sync(self) -> None:
        """Force every row written so far to disk (the end of a run, before its export)."""
        if not self._unsynced or not self.path.is_file():
            return
        with open(self.path, "rb") as handle:
            self._fsync(handle.fileno())

    def _fsync(self, descriptor: int) -> None:
        os.fsync(descriptor)
        self._synced_at = time.monotonic()
        self._unsynced = False

    def _separator(self) -> str:
        """A newline if the file ends in a torn line, so the next row starts on its own line."""
        try:
            with open(self.path, "rb") as handle:
                handle.seek(0, os.SEEK_END)
                if handle.tell() == 0:
                    return ""
                handle.seek(-1, os.SEEK_END)
                return "" if handle.read(1) == b"\n" else "\n"
        except FileNotFoundError:
            return ""

    # -- reading ------------------------------------------------------------------------------

    def exists(self) -> bool:
        return any((self.run_dir / name).is_file() for name in (JSONL_NAME, PARQUET_NAME, CSV_NAME))

    def rows(self) -> Iterator[dict[str, Any]]:
        """The parsed rows of ``episodes.jsonl`` in file order; torn or corrupt lines skipped."""
        self.skipped_lines = []
        if not self.path.is_file():
            return
        with open(self.path, encoding="utf-8", errors="replace") as handle:
            for number, line in enumerate(handle, start=1):
                text = line.strip()
                if not text:
                    continue
                try:
                    row = json.loads(text)
                except json.JSONDecodeError:
                    row = None
                if not isinstance(row, dict) or not row.get("episode_id"):
                    # A line torn by a crash (the last one, or one a resumed run wrote past).
                    self.skipped_lines.append(number)
                    continue
                yield row

    def completed_ids(self, *, include_errors: bool = True) -> set[str]:
        """Episode ids that have a row; without ``include_errors``, ids whose last row is an
        ``error`` (a crash or an input problem) count as not done, so a resume runs them again."""
        if self.path.is_file():
            last = {str(row["episode_id"]): row.get("failure_reason") for row in self.rows()}
        elif self.exists():
            frame = self.load()
            last = dict(zip(frame["episode_id"], frame["failure_reason"], strict=True))
        else:
            return set()
        return {key for key, reason in last.items() if include_errors or reason != "error"}

    def load(self) -> pd.DataFrame:
        """All episodes as a typed DataFrame, one row per episode id (the last one written)."""
        if self.path.is_file():
            return self._load_jsonl()
        if (self.run_dir / PARQUET_NAME).is_file():
            frame = read_parquet(self.run_dir / PARQUET_NAME, what="episode table")
            check_episode_columns(frame, self.run_dir / PARQUET_NAME)
        elif (self.run_dir / CSV_NAME).is_file():
            frame = read_episodes_csv(self.run_dir / CSV_NAME, typed=False)
        else:
            frame = pd.DataFrame(columns=list(SCHEMA))
        return self._typed(frame)

    def _typed(self, frame: pd.DataFrame) -> pd.DataFrame:
        if "episode_id" in frame.columns and len(frame):
            frame = frame.drop_duplicates("episode_id", keep="last")
        try:
            return typed_frame(frame)
        except ValueError as exc:
            raise HarnessError(f"{self.run_dir}: bad episode rows: {exc}") from None

    def _load_jsonl(self) -> pd.DataFrame:
        """``load`` of ``episodes.jsonl``, parsed again only when its bytes changed."""
        path = self.path.resolve()
        digest = hashlib.blake2b(path.read_bytes(), digest_size=16).digest()  # ~1 ms a MB
        cached = _LAST_LOAD.get(path)
        if cached is not None and cached[0] == digest:
            self.skipped_lines = list(cached[2])
            return cached[1].copy()
        frame = self._typed(pd.DataFrame(list(self.rows())))
        _LAST_LOAD.clear()
        _LAST_LOAD[path] = (digest, frame.copy(), list(self.skipped_lines))
        return frame

    def export(self) -> tuple[Path, Path]:
        """Write ``episodes.csv`` and ``episodes.parquet`` from the store; return their paths."""
        self.sync()
        frame = self.load()
        self.run_dir.mkdir(parents=True, exist_ok=True)
        csv_path = self.run_dir / CSV_NAME
        parquet_path = self.run_dir / PARQUET_NAME
        _atomic_write(csv_path, lambda tmp: frame.to_csv(tmp, index=False))
        _atomic_write(parquet_path, lambda tmp: frame.to_parquet(tmp, index=False))
        return csv_path, parquet_path


# The columns every reader of an episode table needs (the episode, where it ran, its
# verdict): a table without them is not a run's, however it parses (a CSV of other columns
# compared as "0 matched" and exited 0).
REQUIRED_COLUMNS = ("episode_id", "robot", "arm", "object", "success")


def check_episode_columns(frame: pd.DataFrame, path: Path) -> None:
    """``HarnessError`` naming ``path`` when ``frame`` lacks a ``REQUIRED_COLUMNS`` column."""
    missing = [name for name in REQUIRED_COLUMNS if name not in frame.columns]
    if missing:
        raise HarnessError(
            f"{path}: not an episode table (no {', '.join(repr(m) for m in missing)} "
            f"column{'s' if len(missing) > 1 else ''})"
        )


def read_episodes_csv(path: str | Path, typed: bool = True) -> pd.DataFrame:
    """Read an ``episodes.csv`` (exported, or hand-made with a subset of the columns).

    Empty cells of string columns read back as ``""``; with ``typed`` the frame gets the schema
    types. A file that is not an episode table raises ``HarnessError`` naming it.
    """
    path = Path(path)
    string_columns: dict[Hashable, str] = {
        name: "str" for name, c in SCHEMA.items() if c.dtype == "str"
    }
    frame = read_csv(
        path,
        what="the episode table",
        dtype=string_columns,
        keep_default_na=False,
        na_values=[""],
    )
    if "episode_id" not in frame.columns:
        raise HarnessError(f"{path}: not an episode table (no 'episode_id' column)")
    for name in string_columns:
        if name in frame.columns:
            frame[name] = frame[name].fillna("")
    if not typed:
        check_episode_columns(frame, path)
        return frame
    try:
        typed_rows = typed_frame(frame)
    except ValueError as exc:
        raise HarnessError(f"{path}: {exc}") from None
    check_episode_columns(frame, path)  # after typing: a bad cell is named first
    return typed_rows


def _atomic_write(path: Path, write: Any) -> None:
    """Write via a temporary file and rename, so readers never see half a file; a failed write
    names ``path`` and leaves no temp file (``harness.writes``)."""
    write_through(path, write, root=path.parent)
