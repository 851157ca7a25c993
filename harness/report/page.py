"""``report.html``: one self-contained, interactive page that opens offline, rendered with a
Jinja2 template (``harness.report.page_template``, autoescaped).

At the top the objective and the answer per robot, arm and object (``harness.report.answer``;
a tune's decisions first: ``harness.report.tune_link``); below, each in a folded section, the
summary (what to change, with its evidence: ``harness.report.findings``), the run's details and
the contents, then plotly.js embedded once (no CDN) with the interactive heatmaps coloured by
the objective (open; one per robot, arm and object, hover for intervals, n, failures, in each
axis's own order), the outcome vs placement plot, the tables (sort on a click on a header,
filter by typing above them), episode ids linked to their recordings with how to open them, the
replayed videos with their posters and captions, and the static plots, embedded as base64. A
link to a folded section opens it.
"""

from __future__ import annotations

import base64
import re
from collections.abc import Mapping, Sequence
from itertools import groupby
from pathlib import Path
from typing import Any

import pandas as pd

from harness.report.answer import NO_SETTING, FirstScreen
from harness.report.findings import MIN_SHARE, Finding
from harness.report.heatmaps import Heatmap
from harness.report.objective import VALID, other
from harness.report.page_template import FIGURE, TEMPLATE
from harness.report.render import PLOT_CAPTIONS
from harness.report.sections import FALLBACK_MARK, Table, overview
from harness.report.videos import Clip

STYLE = """
body { font-family: -apple-system, 'Segoe UI', Helvetica, Arial, sans-serif; color: #1f2328;
       max-width: 1300px; margin: 2em auto; padding: 0 1.5em; line-height: 1.45; }
h1 { border-bottom: 2px solid #d0d7de; padding-bottom: .3em; }
h2 { margin-top: 1.8em; border-bottom: 1px solid #d0d7de; padding-bottom: .2em; }
h3 { margin: 1.2em 0 .3em; }
dl.overview { display: grid; grid-template-columns: max-content auto; gap: .2em 1.2em; }
dl.overview dt { font-weight: 600; color: #57606a; }
dl.overview dd { margin: 0; }
table { border-collapse: collapse; margin: .6em 0 1em; font-size: 0.88em; }
th, td { border: 1px solid #d0d7de; padding: .25em .55em; text-align: left; }
th { background: #f6f8fa; cursor: pointer; user-select: none; white-space: nowrap; }
th.asc::after { content: " ▲"; font-size: .75em; }
th.desc::after { content: " ▼"; font-size: .75em; }
tr:nth-child(even) td { background: #fbfcfd; }
tr.flag td { background: #fff8c5; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
td.msg { max-width: 38em; font-family: ui-monospace, monospace; font-size: .92em; }
p.note { color: #57606a; font-size: .9em; margin: .2em 0; }
.heatmaps { display: flex; flex-wrap: wrap; gap: .4em 1em; }
.heatmaps > div { border: 1px solid #eaeef2; border-radius: 6px; }
.videos { display: flex; flex-wrap: wrap; gap: 1em; }
.videos figure { margin: 0; }
video { width: 640px; max-width: 100%; aspect-ratio: 4 / 3; background: #24292f;
        border-radius: 6px; }
figure { margin: 1em 0 2em; }
figure img { max-width: 100%; border: 1px solid #d0d7de; border-radius: 6px; }
figcaption { color: #57606a; font-size: .85em; margin-top: .3em; max-width: 640px; }
ul.findings li { margin: .4em 0; }
p.lede { font-size: 1.02em; margin: .2em 0 .6em; }
#answer h2 { margin-top: .6em; }
table.answer { font-size: .9em; }
table.answer th { cursor: default; }
table.answer td { vertical-align: top; }
td.decision { font-weight: 600; white-space: nowrap; }
td.decision.go { background: #dafbe1 !important; }
td.decision.keep { background: #eaeef2 !important; }
td.decision.none { background: #ffebe9 !important; }
td.decision.wait { background: #fff8c5 !important; }
details.section > summary h2 { display: inline; border: none; font-size: 1.25em; margin: 0; }
details.section > summary { margin-top: .7em; padding-bottom: .15em;
                            border-bottom: 1px solid #d0d7de; }
span.count { color: #57606a; font-size: .9em; }
span.evidence { color: #57606a; font-size: .9em; }
nav.contents ol { columns: 2; font-size: .92em; }
input.filter { margin: .3em 0 0; padding: .2em .4em; width: 18em; font-size: .85em; }
details > summary { cursor: pointer; color: #0969da; margin: .4em 0; }
.videos figure { border-top: 4px solid #d0d7de; padding-top: .3em; }
.videos figure.valid { border-color: #2da44e; }
.videos figure.invalid { border-color: #e3a21a; }
.videos figure.failed { border-color: #cf222e; }
.plots figcaption { max-width: none; }
"""

# Click a header to sort by it (again: reverse). Cells sort as numbers when they start with one
# ("3/4" by its ratio, "75%", "0.30–0.95" by the lower bound), otherwise as text.
SORTER = """
(function () {
  function key(text) {
    var t = text.trim().replace(/^\u2691\\s*/, '');
    var m = t.match(/^(-?\\d+)\\/(\\d+)/);
    if (m) { return Number(m[2]) ? Number(m[1]) / Number(m[2]) : -1; }
    m = t.match(/^-?\\d[\\d,]*(\\.\\d+)?/);
    if (m) { return parseFloat(m[0].replace(/,/g, '')); }
    return null;
  }
  document.querySelectorAll('table.sortable').forEach(function (table) {
    table.querySelectorAll('th').forEach(function (th, index) {
      th.addEventListener('click', function () {
        var body = table.tBodies[0], rows = Array.from(body.rows);
        var up = !th.classList.contains('asc');
        table.querySelectorAll('th').forEach(function (h) { h.classList.remove('asc', 'desc'); });
        th.classList.add(up ? 'asc' : 'desc');
        rows.sort(function (a, b) {
          var x = a.cells[index].textContent, y = b.cells[index].textContent;
          var kx = key(x), ky = key(y), order;
          if (kx !== null && ky !== null) { order = kx - ky; }
          else if (kx !== null) { order = -1; } else if (ky !== null) { order = 1; }
          else { order = x.localeCompare(y); }
          return up ? order : -order;
        });
        rows.forEach(function (row) { body.appendChild(row); });
      });
    });
  });
})();
"""

# A link to a section inside a folded <details> opens it (contents, #placement, ...).
OPEN_TARGET = """
(function () {
  function open() {
    var id = location.hash ? decodeURIComponent(location.hash.slice(1)) : '';
    var el = id ? document.getElementById(id) : null;
    for (; el; el = el.parentElement) { if (el.tagName === 'DETAILS') { el.open = true; } }
  }
  window.addEventListener('hashchange', open);
  open();
})();
"""

NUMERIC_MARKS = ("%", "/", "–", ".", ",", FALLBACK_MARK, " ")

# Type in the box above a table to keep only the rows that contain the text.
FILTER = """
(function () {
  document.querySelectorAll('input.filter').forEach(function (box) {
    var table = box.nextElementSibling;
    box.addEventListener('input', function () {
      var text = box.value.toLowerCase();
      Array.from(table.tBodies[0].rows).forEach(function (row) {
        row.style.display = row.textContent.toLowerCase().indexOf(text) >= 0 ? '' : 'none';
      });
    });
  });
})();
"""


def _numeric(text: str) -> bool:
    stripped = text
    for mark in NUMERIC_MARKS:
        stripped = stripped.replace(mark, "")
    return bool(stripped) and stripped.replace("-", "").isdigit()


def _slug(text: str, taken: set[str]) -> str:
    base = re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-") or "section"
    slug, k = base, 2
    while slug in taken:
        slug, k = f"{base}-{k}", k + 1
    taken.add(slug)
    return slug


def _cells(table: Table, i: int, row: list[str]) -> list[dict[str, Any]]:
    cells = []
    for j, text in enumerate(row):
        pieces = table.links.get((i, j))
        linked = [{"text": t, "href": h} for t, h in pieces] if pieces is not None else None
        cls = "msg" if table.header[j] == "message" else ("num" if _numeric(text) else "")
        cells.append({"pieces": linked or [{"text": text, "href": None}], "cls": cls})
    return cells


def _table_context(table: Table, taken: set[str]) -> dict[str, Any]:
    rows = [
        {"cells": _cells(table, i, row), "flag": i in table.flagged}
        for i, row in enumerate(table.rows)
    ]
    return {
        "id": _slug(table.title, taken),
        "title": table.title,
        "note": table.note,
        "header": table.header,
        "rows": rows,
    }


MEANING = {
    "valid": "the grasp really holds: no table penetration, two fingers, hold, tug",
    "reference": "InternDataEngine's is_success verdict",
}


def decision_kind(decision: str) -> str:
    """The colour class of a decision cell: go (switch / best swept), keep, none, wait."""
    if decision.startswith(NO_SETTING) or decision.startswith("no rated"):
        return "none"
    if decision.startswith("undecided"):
        return "wait"
    if decision.startswith(("keep", "tie")):
        return "keep"
    return "go"


def _answer_context(table: Table) -> dict[str, Any]:
    rows = [
        {"cells": _cells(table, i, row), "kind": decision_kind(row[1]) if len(row) > 1 else ""}
        for i, row in enumerate(table.rows)
    ]
    return {"title": table.title, "note": table.note, "header": table.header, "rows": rows}


def _data_uri(path: Path, mime: str) -> str:
    return f"data:{mime};base64," + base64.b64encode(path.read_bytes()).decode("ascii")


def _figure(name: str, path: Path) -> dict[str, str]:
    return {"caption": PLOT_CAPTIONS.get(name, name), "src": _data_uri(path, "image/png")}


def _clip_context(run_dir: Path, clip: Clip, links: Mapping[str, str]) -> dict[str, Any]:
    video = run_dir / clip.path if clip.path is not None else None
    poster = run_dir / clip.poster if clip.poster is not None else None
    return {
        "headline": clip.headline or clip.outcome,
        "kind": clip.kind or ("valid" if clip.outcome == "success" else "failed"),
        "robot": clip.robot,
        "arm": clip.arm,
        "object": clip.object,
        "seed": clip.seed,
        "episode_id": clip.episode_id,
        "recording": clip.recording or links.get(clip.episode_id),
        "note": clip.note,
        "video": _data_uri(video, "video/mp4") if video is not None and video.is_file() else "",
        "poster": _data_uri(poster, "image/png") if poster is not None and poster.is_file() else "",
    }


def render_page(
    run_dir: Path,
    frame: pd.DataFrame,
    tables: list[Table],
    plots: dict[str, Path],
    heatmaps: Sequence[Heatmap] = (),
    clips: Sequence[Clip] = (),
    links: Mapping[str, str] | None = None,
    findings: Sequence[Finding] = (),
    screen: FirstScreen | None = None,
) -> str:
    """The whole page (Jinja2, autoescaped): the first screen's answers (``screen``), then
    everything else folded. The static success plot is left out when the heatmaps show it."""
    from jinja2 import Environment
    from plotly.offline import get_plotlyjs  # only when a page is drawn

    env = Environment(autoescape=True, trim_blocks=False)
    template = env.from_string(FIGURE + TEMPLATE)
    screen = screen or FirstScreen([], VALID)
    objective = screen.objective
    taken = {"summary", "heatmaps", "placement", "recordings", "videos", "plots", "answer"}
    table_contexts = [_table_context(t, taken) for t in tables]
    others = {n: p for n, p in plots.items() if n not in ("success", "placement")}
    contents = [("answer", "Answer"), ("summary", "Summary: what to change")]
    if heatmaps or "success" in plots:
        contents.append(("heatmaps", f"{objective.capitalize()} rate over the swept settings"))
    if "placement" in plots:
        contents.append(("placement", "Outcome vs placement per robot arm"))
    contents += [(t["id"], t["title"]) for t in table_contexts]
    if clips:
        contents.append(("videos", "Videos"))
    if others:
        contents.append(("plots", "Plots"))
    return template.render(
        name=run_dir.name,
        title_name=(
            f"{screen.tune_path.name} ({run_dir.name} run)" if screen.tune_path else run_dir.name
        ),
        style=STYLE,
        plotly_js=get_plotlyjs() if heatmaps else "",
        overview=overview(run_dir, frame),
        objective=objective,
        objective_meaning=MEANING.get(objective, objective),
        other_objective=other(objective),
        objective_note=screen.note,
        cell_text=(
            "valid successes / judged episodes, rate, reference successes / rated episodes"
            if objective == VALID
            else "reference successes / rated episodes, rate, valid successes / judged episodes"
        ),
        tune_path=str(screen.tune_path) if screen.tune_path else "",
        tune_links=screen.tune_links,
        answers=[_answer_context(t) for t in screen.tables],
        findings=list(findings),
        min_share=f"{MIN_SHARE:.0%}",
        contents=contents,
        heatmaps=[(robot, list(maps)) for robot, maps in groupby(heatmaps, key=lambda h: h.robot)],
        fallback_mark=FALLBACK_MARK,
        fallback_cells=sum(h.fallback_cells for h in heatmaps),
        success_plot=_figure("success", plots["success"]) if "success" in plots else None,
        placement=_figure("placement", plots["placement"]) if "placement" in plots else None,
        tables=table_contexts,
        clips=[_clip_context(run_dir, c, links or {}) for c in clips],
        plots=[_figure(n, p) for n, p in others.items()],
        sorter=SORTER + FILTER + OPEN_TARGET,
    )
