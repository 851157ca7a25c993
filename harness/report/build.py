"""Building a run's report: ``build_report(run_dir)`` writes

- ``summary.csv``: one row per sweep point and task (task, robot, arm, object, point, the
  ``param.*`` values): n, successes, rate, 95% Wilson interval, ``fail.<reason>`` counts for
  the whole failure taxonomy, and medians of the candidate counts and wall time;
- ``best.csv``: per robot, the point with the highest Wilson lower bound (pooled over the robot's
  arms and objects), so a lucky 2/2 does not beat a solid 18/20;
- ``plots/``: success over the swept axes, failure reasons per point, the candidate funnel;
- ``report.md`` (tables + plot links) and ``report.html`` (self-contained, plots embedded).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from harness.files import write_atomic
from harness.report.plots import plot_failures, plot_funnel, plot_success
from harness.report.render import render_html, render_markdown
from harness.report.sections import report_tables
from harness.report.tables import best_settings, funnel, load_episodes, summarize
from harness.runs.store import JSONL_NAME, ResultStore

SUMMARY_NAME = "summary.csv"


BEST_NAME = "best.csv"


@dataclass(frozen=True)
class ReportPaths:
    """Everything ``build_report`` wrote."""

    run_dir: Path
    summary_csv: Path
    best_csv: Path
    report_md: Path
    report_html: Path
    plots: dict[str, Path] = field(default_factory=dict)


def build_report(
    run_dir: str | Path, export: bool = False, objective: str = "reference"
) -> ReportPaths:
    """Rebuild summary.csv, best.csv, plots/, report.md and report.html of ``run_dir``.

    With ``export`` the store is also re-exported to episodes.csv / episodes.parquet (only when
    it has an ``episodes.jsonl``; a hand-made episodes.csv is never overwritten). ``objective``
    ranks the best settings by the reference success rate or by the valid rate.
    """
    run_dir = Path(run_dir)
    frame = load_episodes(run_dir)
    if export and (run_dir / JSONL_NAME).is_file():
        ResultStore(run_dir).export()
    summary = summarize(frame)
    best = best_settings(summary, objective)
    summary_csv = run_dir / SUMMARY_NAME
    best_csv = run_dir / BEST_NAME
    write_atomic(summary_csv, summary.to_csv(index=False))  # whole or absent, never half
    write_atomic(best_csv, best.to_csv(index=False))

    plots_dir = run_dir / "plots"
    plots_dir.mkdir(exist_ok=True)
    plots = {
        "success": plot_success(summary, plots_dir / "success.png"),
        "failures": plot_failures(summary, plots_dir / "failures.png"),
        "funnel": plot_funnel(funnel(frame), plots_dir / "funnel.png"),
    }
    tables = report_tables(frame, summary, best)
    report_md = run_dir / "report.md"
    report_html = run_dir / "report.html"
    write_atomic(report_md, render_markdown(run_dir, frame, tables, plots))
    write_atomic(report_html, render_html(run_dir, frame, tables, plots))
    return ReportPaths(run_dir, summary_csv, best_csv, report_md, report_html, plots)
