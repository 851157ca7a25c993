"""A run directory and its lifecycle, shared by ``harness sweep`` and ``harness run``.

Created with ``sweep.yaml`` (the sweep as run, every task inlined, so ``--resume`` needs nothing
else) and, for InternDataEngine tasks, the mapping notes; reopened by ``--resume``; filled row by
row through the append-only ``ResultStore``; finalized into ``episodes.csv`` /
``episodes.parquet``. The report and the sweep overview recording are built afterwards by the
layer that started the run (``harness.report.finish.finish_run``): ``runs`` does not import
``report``.
"""

from __future__ import annotations

import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import yaml

from harness.config import ConfigError, SweepConfig, TaskConfig, load_sweep
from harness.errors import DiskFullError
from harness.files import is_disk_full
from harness.interndata import NOTES_FILE, write_notes
from harness.runs.inputs import INPUTS_NAME, check_inputs, record_inputs
from harness.runs.safety import (
    LOCK_NAME,
    RunLock,
    check_sweep_hash,
    record_sweep_hash,
    refuse_symlinks,
    safe_file_name,
    sweep_hash,
    with_hash_header,
)
from harness.runs.store import CSV_NAME, JSONL_NAME, PARQUET_NAME, ResultStore
from harness.runs.worker import DISK_FULL_PREFIX, recording_disk_full
from harness.writes import check_outputs, write_file

SWEEP_YAML = "sweep.yaml"
LOG_NAME = "MUJOCO_LOG.TXT"  # harness.sim.mujoco_log.LOG_NAME (not imported: loads MuJoCo)
# Everything a run writes at its top level: a planted symlink among them is refused. The report's
# and the recording's names are spelled here (importing them would load matplotlib and rerun).
RUN_OUTPUTS = (
    SWEEP_YAML,
    NOTES_FILE,
    JSONL_NAME,
    *(name for base in (CSV_NAME, PARQUET_NAME) for name in (base, f".{base}.tmp")),
    INPUTS_NAME,
    "summary.csv",
    "best.csv",
    "report.md",
    "report.html",
    "recording.rrd",
    "episodes",
    "plots",
    "videos",
    "audit",
    "tune",
    LOG_NAME,
)


# The run directory this process last created or resumed: a second Ctrl-C (or SIGTERM), which
# ends the process wherever it is, can still say what was kept and how to continue.
_LAST_RUN: list[Path] = []


def interrupted_line() -> str:
    """``interrupted: N finished episode(s) are kept in RUN/episodes.jsonl; continue with
    harness sweep --resume RUN`` for the run this process filled; bare "interrupted" without."""
    if not _LAST_RUN:
        return "interrupted"
    path = _LAST_RUN[-1]
    try:
        kept = len(ResultStore(path).completed_ids(include_errors=True))
    except Exception:  # a half-written store: the resume command still holds
        return f"interrupted: continue with harness sweep --resume {path}"
    return (
        f"interrupted: {kept} finished episode(s) are kept in {path / JSONL_NAME}; continue "
        f"with harness sweep --resume {path}"
    )


OUTPUT_FOLDERS = ("episodes", "plots", "videos", "audit", "tune")


def refuse_unwritable(run_dir: Path) -> None:
    """Before any episode: no symlink among the run's outputs (one line naming it, as
    ``refuse_symlinks`` words it), and no special file (a FIFO, a device) among them or inside
    its output folders: a write hours later would be refused (``harness.writes``)."""
    refuse_symlinks(run_dir, RUN_OUTPUTS)
    files = tuple(name for name in RUN_OUTPUTS if name not in OUTPUT_FOLDERS)
    check_outputs(run_dir, (*files, LOCK_NAME), OUTPUT_FOLDERS)


def claim_new_dir(base: Path) -> Path:
    """Create ``base`` itself (``mkdir`` fails if it exists), else the first free ``base-2``,
    ``base-3``, ...: runs started in the same second never share a default directory."""
    base.parent.mkdir(parents=True, exist_ok=True)
    for number in range(1, 10_000):
        name = base.name if number == 1 else safe_file_name(f"{base.name}-{number}")
        candidate = base.with_name(name)
        try:
            candidate.mkdir()
        except FileExistsError:
            continue
        return candidate
    raise ConfigError("no free run directory name; give --out", file=base)


def resolved_sweep_document(sweep: SweepConfig, tasks: list[TaskConfig]) -> dict[str, Any]:
    """The sweep as run: its settings with every task inlined (self-contained for --resume)."""
    data = sweep.model_dump(mode="json")
    data["tasks"] = [
        task.model_dump(mode="json", exclude={"source"}, exclude_none=True) for task in tasks
    ]
    return data


class RunDir:
    """One run directory: its ``sweep.yaml``, its episode store, its exports and report."""

    def __init__(self, path: Path, *, unique: bool = False) -> None:
        """``unique``: ``path`` is a default name; ``create`` claims it, or ``path-2``, ... ."""
        self.path = path
        self.unique = unique
        self.store = ResultStore(path)
        self.lock = RunLock(path)
        self.config_sha256: str | None = None  # stored in every row this process appends

    @staticmethod
    def default_path(name: str) -> Path:
        """``reports/<name>-<date>-<time>``: where a run goes without ``--out`` (claimed with
        ``claim_new_dir``: two runs started in the same second get two directories)."""
        return Path("reports") / safe_file_name(f"{name}-{time.strftime('%Y%m%d-%H%M%S')}")

    @classmethod
    def default(cls, name: str) -> RunDir:
        """The run directory of a run without ``--out`` (claimed at ``create``)."""
        return cls(cls.default_path(name), unique=True)

    @classmethod
    def existing(cls, path: Path, *, force: bool = False) -> RunDir:
        """A run directory to resume, locked for this process; it must hold a ``sweep.yaml``
        unchanged since the run was created (unless ``force``) and no symlinked outputs."""
        run = cls(path)
        if not run.sweep_yaml.is_file():
            raise ConfigError("not a run directory (no sweep.yaml)", file=path)
        refuse_unwritable(path)
        run.lock.acquire()
        try:
            hashes = (str(row.get("config_sha256") or "") for row in run.store.rows())
            run.config_sha256 = check_sweep_hash(path, run.sweep_yaml, force, hashes)
            if not force:
                check_inputs(path)  # an edited mesh or grasp file: refused too
            _LAST_RUN[:] = [path]
        except BaseException:
            run.lock.release()
            raise
        return run

    @property
    def sweep_yaml(self) -> Path:
        return self.path / SWEEP_YAML

    def load_sweep(self) -> SweepConfig:
        """The sweep this directory was created with (tasks inlined)."""
        return load_sweep(self.sweep_yaml)

    def create(
        self,
        sweep: SweepConfig,
        tasks: list[TaskConfig],
        *,
        taken: str,
        inputs: Iterable[str] = (),
    ) -> None:
        """Write ``sweep.yaml`` (and ``inputs.sha256``, the hashes of the files ``inputs`` the
        tasks load) and lock the directory for this process; a directory that already holds a
        run raises ``taken``, one with symlinked outputs or foreign files is refused."""
        if self.unique:
            self._claim()
        if self.path.exists() and not self.path.is_dir():
            raise ConfigError(
                "is not a directory (a run directory is a folder; give a new or empty one)",
                file=self.path,
            )
        if self.path.exists():
            refuse_unwritable(self.path)
            self._refuse_foreign_files()
        self.lock.acquire()
        if self.sweep_yaml.exists():
            self.lock.release()
            raise ConfigError(taken, file=self.path)
        body = yaml.safe_dump(resolved_sweep_document(sweep, tasks), sort_keys=False)
        write_file(self.sweep_yaml, with_hash_header(body), root=self.path)
        record_sweep_hash(self.path, self.sweep_yaml)
        record_inputs(self.path, inputs)
        self.config_sha256 = sweep_hash(self.sweep_yaml)
        _LAST_RUN[:] = [self.path]

    def _claim(self) -> None:
        candidate = claim_new_dir(self.path)
        self.path, self.unique = candidate, False
        self.store, self.lock = ResultStore(candidate), RunLock(candidate)

    def _refuse_foreign_files(self) -> None:
        """A folder that holds files but no run (``report.md``, a stray ``episodes.jsonl``) is
        refused: a run never writes over files it did not make, nor mixes in foreign rows."""
        if self.sweep_yaml.exists():
            return  # a run: refused as ``taken`` under the lock
        foreign = sorted(p.name for p in self.path.iterdir() if p.name != LOCK_NAME)
        if foreign:
            more = f" and {len(foreign) - 1} more" if len(foreign) > 1 else ""
            raise ConfigError(
                f"is not empty and holds no run (no sweep.yaml; it holds {foreign[0]}{more}): "
                "a run never writes over files it did not make; give a new or empty folder",
                file=self.path,
            )

    def write_notes(self, notes: list[str]) -> Path:
        """The InternDataEngine mapping notes (skipped skills, ignored keys, approximations)."""
        return write_notes(self.path, notes)

    def completed_ids(self, *, retry_errors: bool = False) -> set[str]:
        """Episode ids that already have a row (a resumed run skips them); with
        ``retry_errors``, episodes whose row is an ``error`` are not counted as done."""
        return self.store.completed_ids(include_errors=not retry_errors)

    def append(self, row: dict[str, Any]) -> None:
        """Store one episode's row (crash-safe). A full disk (writing the row, or the row's
        recording) stops the run with ``DiskFullError`` once every row that fits is stored."""
        if self.config_sha256 is not None:
            row = {**row, "config_sha256": self.config_sha256}
        try:
            self.store.append(row)
        except OSError as exc:
            if is_disk_full(exc):
                raise self.disk_full(str(exc)) from None
            raise
        if recording_disk_full(row):
            raise self.disk_full(str(row["recording_error"]))

    def disk_full(self, detail: str) -> DiskFullError:
        """The one-line stop of a run whose disk is full: what is kept, how to continue."""
        kept = len(self.store.completed_ids(include_errors=True))
        return DiskFullError(
            f"disk full under {self.path} ({detail.removeprefix(DISK_FULL_PREFIX)}): the run "
            f"stopped; {kept} finished episode(s) are kept in {JSONL_NAME}; free space, then "
            f"harness sweep --resume {self.path}"
        )

    def finalize(self) -> None:
        """Export the store to episodes.csv / episodes.parquet; unlock. (The caller then builds
        the report: ``harness.report.finish.finish_run``.)"""
        try:
            self.store.export()
        except OSError as exc:
            if is_disk_full(exc):
                raise self.disk_full(str(exc)) from None
            raise
        finally:
            self.lock.release()
