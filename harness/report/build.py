"""Building a run's report: ``build_report(run_dir)`` writes

- ``summary.csv``: one row per sweep point and task (task, robot, arm, object, point, the
  ``param.*`` values): n, successes, rate, 95% Wilson interval, the valid rate and its interval,
  ``fallback`` (episodes whose candidates came from the reference fallback), ``errors`` (rows
  left out of every rate), ``fail.<reason>`` counts for the whole failure taxonomy, and medians
  of the candidate counts and wall time;
- ``best.csv``: per robot, arm and object, the point with the highest Wilson lower bound over
  the swept settings, so a lucky 2/2 does not beat a solid 18/20;
- ``plots/``: success per robot, arm and object over the swept settings, failure reasons per
  point, the candidate funnel;
- ``plots/placement.png``: outcome vs the object's placement per robot arm (reach);
- ``videos/`` (with ``videos=True``): one episode per outcome class and one success and one
  failure per robot arm, replayed (kept on the page by later reports without ``videos``);
- ``report.md`` (tables, links, plot links) and ``report.html`` (self-contained and interactive:
  plotly heatmaps, sortable tables, embedded plots and videos; ``harness.report.page``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from harness.files import refuse_planted_links, write_atomic
from harness.report import failure_groups
from harness.report.episode_sections import (
    errors_table,
    examples_table,
    failure_groups_table,
    recording_links,
)
from harness.report.findings import findings
from harness.report.heatmaps import success_heatmaps
from harness.report.labels import varying_params
from harness.report.page import render_page
from harness.report.placement import plot_placement
from harness.report.plots import plot_failures, plot_funnel, plot_success
from harness.report.render import render_markdown
from harness.report.sections import Table, funnel_tables, report_tables
from harness.report.sensitivity import sensitivity_tables
from harness.report.tables import (
    best_settings,
    error_rows,
    funnel,
    load_episodes,
    rated,
    setting_params,
    summarize,
)
from harness.report.videos import Clip, load_clips, render_clips
from harness.runs.store import JSONL_NAME, ResultStore

SUMMARY_NAME = "summary.csv"


BEST_NAME = "best.csv"
# Everything ``build_report`` writes (with ``export``, the episode tables too; with ``videos``,
# replays that log to MuJoCo's log), and the run's recording.
REPORT_OUTPUTS = (
    "MUJOCO_LOG.TXT",
    "recording.rrd",
    SUMMARY_NAME,
    BEST_NAME,
    "plots",
    "videos",
    "report.md",
    "report.html",
    "episodes.csv",
    "episodes.parquet",
    ".episodes.csv.tmp",
    ".episodes.parquet.tmp",
)


@dataclass(frozen=True)
class ReportPaths:
    """Everything ``build_report`` wrote."""

    run_dir: Path
    summary_csv: Path
    best_csv: Path
    report_md: Path
    report_html: Path
    plots: dict[str, Path] = field(default_factory=dict)
    videos: list[Clip] = field(default_factory=list)


def group_failures(frame: pd.DataFrame) -> pd.DataFrame:
    """Failure messages of the rated episodes (``error`` rows have their own table) grouped per
    robot, arm and reason by their normalised pattern (``harness.report.failure_groups``)."""
    return failure_groups.group_failures(rated(frame))


def episode_tables(run_dir: Path, frame: pd.DataFrame, summary: pd.DataFrame) -> list[Table]:
    """Error rows, grouped failure messages and example episodes, ids linked to recordings."""
    links = recording_links(run_dir, frame)
    params = setting_params(summary) or varying_params(summary)
    tables: list[Table] = []
    errors = error_rows(frame)
    if len(errors):
        tables.append(errors_table(errors, params, links))
    groups = group_failures(frame)
    if len(groups):
        tables.append(failure_groups_table(groups, links))
    tables.append(examples_table(frame, params, links))
    return tables


def build_report(
    run_dir: str | Path, export: bool = False, objective: str = "reference", videos: bool = False
) -> ReportPaths:
    """Rebuild summary.csv, best.csv, plots/, report.md and report.html of ``run_dir``.

    With ``export`` the store is also re-exported to episodes.csv / episodes.parquet (only when
    it has an ``episodes.jsonl``; a hand-made episodes.csv is never overwritten). ``objective``
    ranks the best settings by the reference success rate or by the valid rate. ``videos``
    replays one success and one failure per robot arm and embeds their MP4s (a few seconds of
    work per clip).
    """
    run_dir = Path(run_dir)
    refuse_planted_links(run_dir, REPORT_OUTPUTS)  # a write must never follow a planted link
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
    placement = plot_placement(frame, plots_dir / "placement.png")
    if placement is not None:
        plots["placement"] = placement
    tables = [
        *report_tables(frame, summary, best),
        *sensitivity_tables(summary),
        *episode_tables(run_dir, frame, summary),
        *funnel_tables(funnel(frame)),
    ]
    # Without rendering, the videos of an earlier report stay on the page (videos/clips.json).
    clips = render_clips(run_dir, frame) if videos else load_clips(run_dir)
    report_md = run_dir / "report.md"
    report_html = run_dir / "report.html"
    write_atomic(report_md, render_markdown(run_dir, frame, tables, plots, clips))
    links = recording_links(run_dir, frame)
    page = render_page(
        run_dir, frame, tables, plots, success_heatmaps(summary), clips, links,
        findings(frame, best),
    )  # fmt: skip
    write_atomic(report_html, page)
    return ReportPaths(run_dir, summary_csv, best_csv, report_md, report_html, plots, clips)
