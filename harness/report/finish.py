"""Finishing a run: its report and its sweep overview recording, built after the episodes ran.

``harness.runs`` runs the episodes and exports the store (``RunDir.finalize``); it does not know
the report. The layer that started the run (the ``sweep`` / ``run`` commands, ``harness.api``,
``harness tune``) calls :func:`finish_run` afterwards, so ``runs`` and ``report`` depend in one
direction only (report reads the run's store).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

from harness.files import is_disk_full
from harness.report.build import ReportPaths, build_report
from harness.runs.rundir import RunDir


def finish_run(
    run_dir: Path,
    objective: str | None = None,
    videos: bool = False,
    announce: Callable[[str], None] | None = None,
) -> ReportPaths:
    """Build the report of a finalized run (once: ``objective`` and ``videos`` as
    ``build_report``'s; None: the run's recorded objective, else valid) and its sweep overview
    recording (``recording.rrd``, skipped without rerun-sdk). A full disk raises the run's
    one-line ``DiskFullError``.

    ``announce`` gets a line per output as it is written (``report: RUN/report.html (12.0 s)``,
    ``videos: ...``, ``recording: ...``): building them takes seconds to minutes after the last
    episode, which must not look like a hang. The caller says ``writing the report ...``
    before it imports this module (its imports, scipy and matplotlib, take a second)."""
    tell = announce or _silent
    start = time.perf_counter()
    try:
        paths = build_report(run_dir, objective=objective, videos=videos, announce=announce)
    except OSError as exc:
        if is_disk_full(exc):
            raise RunDir(run_dir).disk_full(str(exc)) from None
        raise
    tell(f"report: {paths.report_html} ({time.perf_counter() - start:.1f} s)")
    start = time.perf_counter()
    try:
        from harness.viz.sweep_recording import record_sweep

        recording = record_sweep(run_dir, paths.objective)
    except ImportError:
        return paths
    if recording is not None:
        tell(f"recording: {recording} ({time.perf_counter() - start:.1f} s)")
    return paths


def _silent(line: str) -> None:
    """No announcements (a caller that prints its own lines)."""
