"""The report as documents: ``report.md`` (tables and plot links) and ``report.html`` (one
self-contained page with the plots embedded as base64 PNG).
"""

from __future__ import annotations

import base64
import html
from pathlib import Path

import pandas as pd

from harness.markdown import markdown_table
from harness.report.sections import Table, overview

PLOT_CAPTIONS: dict[str, str] = {
    "success": "Success rate over the swept parameters (cells: successes/episodes)",
    "failures": "Outcome of every episode per point",
    "funnel": "Candidate funnel per robot",
}


def render_markdown(
    run_dir: Path, frame: pd.DataFrame, tables: list[Table], plots: dict[str, Path]
) -> str:
    lines = [f"# pick-harness report: {run_dir.name}", ""]
    lines += [f"- **{key}**: {value}" for key, value in overview(run_dir, frame)]
    lines.append("")
    for table in tables:
        lines += [f"## {table.title}", ""]
        if table.note:
            lines += [table.note, ""]
        lines += markdown_table(table.header, table.rows)
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


HTML_STYLE = """
body { font-family: -apple-system, 'Segoe UI', Helvetica, Arial, sans-serif; color: #1f2328;
       max-width: 1200px; margin: 2em auto; padding: 0 1.5em; line-height: 1.45; }
h1 { border-bottom: 2px solid #d0d7de; padding-bottom: .3em; }
h2 { margin-top: 1.8em; border-bottom: 1px solid #d0d7de; padding-bottom: .2em; }
dl.overview { display: grid; grid-template-columns: max-content auto; gap: .2em 1.2em; }
dl.overview dt { font-weight: 600; color: #57606a; }
dl.overview dd { margin: 0; }
table { border-collapse: collapse; margin: .6em 0 1em; font-size: 0.92em; }
th, td { border: 1px solid #d0d7de; padding: .3em .65em; text-align: left; }
th { background: #f6f8fa; }
tr:nth-child(even) td { background: #fbfcfd; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
p.note { color: #57606a; font-size: .9em; margin: .2em 0; }
figure { margin: 1em 0 2em; }
figure img { max-width: 100%; border: 1px solid #d0d7de; border-radius: 6px; }
figcaption { color: #57606a; font-size: .9em; margin-top: .3em; }
"""


def render_html(
    run_dir: Path, frame: pd.DataFrame, tables: list[Table], plots: dict[str, Path]
) -> str:
    """A self-contained page: the tables, and the plots embedded as base64 PNG."""
    esc = html.escape
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>pick-harness report: {esc(run_dir.name)}</title>",
        f"<style>{HTML_STYLE}</style></head><body>",
        f"<h1>pick-harness report: {esc(run_dir.name)}</h1>",
        '<dl class="overview">',
    ]
    for key, value in overview(run_dir, frame):
        parts.append(f"<dt>{esc(key)}</dt><dd>{esc(str(value))}</dd>")
    parts.append("</dl>")
    for name, path in plots.items():
        if name == "success":  # the headline plot first
            parts.append(_html_figure(name, path))
    for table in tables:
        parts.append(f"<h2>{esc(table.title)}</h2>")
        if table.note:
            parts.append(f'<p class="note">{esc(table.note)}</p>')
        parts.append("<table><thead><tr>")
        parts += [f"<th>{esc(h)}</th>" for h in table.header]
        parts.append("</tr></thead><tbody>")
        for row in table.rows:
            cells = [
                f'<td class="num">{esc(c)}</td>' if _numeric(c) else f"<td>{esc(c)}</td>"
                for c in row
            ]
            parts.append("<tr>" + "".join(cells) + "</tr>")
        parts.append("</tbody></table>")
    others = {name: path for name, path in plots.items() if name != "success"}
    if others:
        parts.append("<h2>Plots</h2>")
        parts += [_html_figure(name, path) for name, path in others.items()]
    parts.append("</body></html>")
    return "\n".join(parts)


def _numeric(text: str) -> bool:
    stripped = text
    for mark in ("%", "/", "–", ".", ","):
        stripped = stripped.replace(mark, "")
    return bool(stripped) and stripped.replace("-", "").isdigit()


def _html_figure(name: str, path: Path) -> str:
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    caption = html.escape(PLOT_CAPTIONS.get(name, name))
    return (
        f'<figure><img alt="{caption}" src="data:image/png;base64,{data}">'
        f"<figcaption>{caption}</figcaption></figure>"
    )
