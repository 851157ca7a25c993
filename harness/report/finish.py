"""Finishing a run: its report and its sweep overview recording, built after the episodes ran.

``harness.runs`` runs the episodes and exports the store (``RunDir.finalize``); it does not know
the report. The layer that started the run (the ``sweep`` / ``run`` commands, ``harness.api``,
``harness tune``) calls :func:`finish_run` afterwards, so ``runs`` and ``report`` depend in one
direction only (report reads the run's store).
"""

from __future__ import annotations

from pathlib import Path

from harness.files import is_disk_full
from harness.report.build import ReportPaths, build_report
from harness.runs.rundir import RunDir


def finish_run(run_dir: Path, objective: str | None = None, videos: bool = False) -> ReportPaths:
    """Build the report of a finalized run (once: ``objective`` and ``videos`` as
    ``build_report``'s; None: the run's recorded objective, else valid) and its sweep overview
    recording (``recording.rrd``, skipped without rerun-sdk). A full disk raises the run's
    one-line ``DiskFullError``."""
    try:
        paths = build_report(run_dir, objective=objective, videos=videos)
    except OSError as exc:
        if is_disk_full(exc):
            raise RunDir(run_dir).disk_full(str(exc)) from None
        raise
    try:
        from harness.viz.sweep_recording import record_sweep

        record_sweep(run_dir, paths.objective)
    except ImportError:
        pass
    return paths
