"""Run reports: per-point success with Wilson intervals, failure breakdown, best settings, plots.

``build_report(run_dir)`` reads the run's episodes (``harness.runs.store.ResultStore``) and writes
summary.csv, best.csv, plots/, report.md and report.html (``harness.report.build``);
``compare_runs(run_a, run_b)`` matches the settings of two runs and tests each rate difference,
paired by seed when it can (``harness.report.compare``). The package's modules, each one concept:

- ``objective``: the run's objective (valid by default, recorded in ``report.json``);
- ``tables``: the run's episodes and the data tables computed from them (DataFrames);
- ``answer``: the first screen (which setting, how sure, why the rest fail);
  ``tune_link``: a tune's decisions on its runs' pages, links from sweeps to tunes;
- ``labels``: parameter values and sweep points as text for people;
- ``sections``: the overview and the rate tables shared by Markdown and HTML;
  ``episode_sections``: error rows, grouped failure messages, example episodes (linked);
- ``plots``: the matplotlib figures; ``heatmaps``: the interactive plotly heatmaps;
- ``videos``: replayed MP4s of one success and one failure per robot arm;
- ``render``: report.md; ``page``: report.html (self-contained, interactive);
- ``stats``: Wilson intervals, two-proportion tests and the exact McNemar test.
"""

from harness.report.build import BEST_NAME, SUMMARY_NAME, ReportPaths, build_report
from harness.report.compare import compare_runs
from harness.report.labels import format_value, point_label, varying_params
from harness.report.tables import (
    FAIL_PREFIX,
    POINT_KEY,
    best_settings,
    error_messages,
    failure_reasons_in,
    failure_totals,
    funnel,
    load_episodes,
    pooled,
    summarize,
)

__all__ = [
    "BEST_NAME",
    "FAIL_PREFIX",
    "POINT_KEY",
    "SUMMARY_NAME",
    "ReportPaths",
    "best_settings",
    "build_report",
    "compare_runs",
    "error_messages",
    "failure_reasons_in",
    "failure_totals",
    "format_value",
    "funnel",
    "load_episodes",
    "point_label",
    "pooled",
    "summarize",
    "varying_params",
]
