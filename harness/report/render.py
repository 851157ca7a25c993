"""The report as Markdown: ``report.md`` (tables, links to recordings, plots and videos).

``report.html``, the interactive page, is written by ``harness.report.page``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import pandas as pd

from harness.markdown import markdown_table, markdown_text
from harness.report.answer import FirstScreen
from harness.report.findings import Finding
from harness.report.sections import Table, overview
from harness.report.videos import Clip

PLOT_CAPTIONS: dict[str, str] = {
    "success": "Success rate over the swept parameters (cells: successes/episodes)",
    "failures": "Outcome of every episode per point",
    "funnel": "Candidate funnel per robot",
    "placement": "Outcome vs the object's placement at reset, per robot arm (reach)",
}


def _markdown_rows(table: Table) -> list[list[str]]:
    """The table's cells, linked pieces as Markdown links ``[id](episodes/x.rrd)``."""
    rows = [list(row) for row in table.rows]
    for (i, j), pieces in table.links.items():
        rows[i][j] = ", ".join(f"[{text}]({href})" if href else text for text, href in pieces)
    return rows


def _first_screen(screen: FirstScreen | None, findings: Sequence[Finding]) -> list[str]:
    lines: list[str] = []
    if screen is not None:
        lines += [f"Objective: **{screen.objective} rate** (--objective)."]
        if screen.note:
            lines[-1] += f" {markdown_text(screen.note)}."
        if screen.tune_path is not None:
            lines[-1] += f" Part of the tune `{markdown_text(screen.tune_path)}`."
        for text, href in screen.tune_links:
            lines[-1] += f" Tune results: [{markdown_text(text)}]({href})."
        lines.append("")
        for table in screen.tables:
            lines += [f"## {markdown_text(table.title)}", ""]
            lines += markdown_table(table.header, table.rows)
            lines.append("")
            if table.note:
                lines += [markdown_text(table.note), ""]
    lines += ["## Summary: what to change", ""]
    if findings:
        lines += [
            f"- **{markdown_text(f.subject)}**: {markdown_text(f.change)}. "
            f"Evidence: {markdown_text(f.evidence)}."
            for f in findings
        ]
    else:
        lines.append("Nothing stands out.")
    lines.append("")
    return lines


def render_markdown(
    run_dir: Path,
    frame: pd.DataFrame,
    tables: list[Table],
    plots: dict[str, Path],
    clips: Sequence[Clip] = (),
    screen: FirstScreen | None = None,
    findings: Sequence[Finding] = (),
) -> str:
    """report.md: the first screen's answers and the summary first, then the run's details,
    the tables, videos and plots."""
    lines = [f"# pick-harness report: {markdown_text(run_dir.name)}", ""]
    lines += _first_screen(screen, findings)
    lines += ["## Run details", ""]
    lines += [f"- **{key}**: {markdown_text(value)}" for key, value in overview(run_dir, frame)]
    lines.append("")
    for table in tables:
        lines += [f"## {markdown_text(table.title)}", ""]
        if table.note:
            lines += [markdown_text(table.note), ""]
        lines += markdown_table(table.header, _markdown_rows(table))
        lines.append("")
    if clips:
        lines += ["## Videos (one per outcome class, one success and one failure per arm)", ""]
        for clip in clips:
            outcome = clip.headline or clip.outcome
            head = markdown_text(
                f"{clip.robot} {clip.arm} {clip.object}, {outcome}: {clip.episode_id}"
            )
            body = f"[{clip.path}]({clip.path})" if clip.path else "no video"
            note = f" ({markdown_text(clip.note)})" if clip.note else ""
            lines.append(f"- {head} (seed {clip.seed}): {body}{note}")
        lines.append("")
    if plots:
        lines += ["## Plots", ""]
        for name, path in plots.items():
            caption = PLOT_CAPTIONS.get(name, name)
            lines += [f"### {caption}", "", f"![{caption}]({path.relative_to(run_dir)})", ""]
    lines += [
        "Files: `summary.csv` (per point), `best.csv`, `episodes.csv` / `episodes.parquet` "
        "(one row per episode).",
        "",
    ]
    return "\n".join(lines)
