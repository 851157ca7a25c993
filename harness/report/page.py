"""``report.html``: one self-contained, interactive page that opens offline.

plotly.js is embedded once (no CDN), followed by the interactive heatmaps (one per robot, arm
and object, hover for intervals, n, failures); the tables sort on a click on their header (a
few lines of inline JavaScript); episode ids link to their recordings in the run directory;
the replayed videos and the static plots are embedded as base64 (MP4, PNG).
"""

from __future__ import annotations

import base64
import html
from collections.abc import Mapping, Sequence
from itertools import groupby
from pathlib import Path

import pandas as pd

from harness.report.heatmaps import Heatmap
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
video { width: 320px; height: 240px; background: #24292f; border-radius: 6px; }
figure { margin: 1em 0 2em; }
figure img { max-width: 100%; border: 1px solid #d0d7de; border-radius: 6px; }
figcaption { color: #57606a; font-size: .85em; margin-top: .3em; max-width: 320px; }
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

NUMERIC_MARKS = ("%", "/", "–", ".", ",", FALLBACK_MARK, " ")


def _numeric(text: str) -> bool:
    stripped = text
    for mark in NUMERIC_MARKS:
        stripped = stripped.replace(mark, "")
    return bool(stripped) and stripped.replace("-", "").isdigit()


def _cell(table: Table, i: int, j: int, text: str) -> str:
    esc = html.escape
    pieces = table.links.get((i, j))
    if pieces is not None:
        inner = ", ".join(
            f'<a href="{esc(href)}" title="recording">{esc(t)}</a>' if href else esc(t)
            for t, href in pieces
        )
    else:
        inner = esc(text)
    if table.header[j] == "message":
        return f'<td class="msg">{inner}</td>'
    return f'<td class="num">{inner}</td>' if _numeric(text) else f"<td>{inner}</td>"


def table_html(table: Table) -> list[str]:
    esc = html.escape
    parts = [f"<h2>{esc(table.title)}</h2>"]
    if table.note:
        parts.append(f'<p class="note">{esc(table.note)}</p>')
    parts.append('<table class="sortable"><thead><tr>')
    parts += [f"<th>{esc(h)}</th>" for h in table.header]
    parts.append("</tr></thead><tbody>")
    for i, row in enumerate(table.rows):
        cells = "".join(_cell(table, i, j, text) for j, text in enumerate(row))
        flag = ' class="flag"' if i in table.flagged else ""
        parts.append(f"<tr{flag}>{cells}</tr>")
    parts.append("</tbody></table>")
    return parts


def heatmaps_html(heatmaps: Sequence[Heatmap]) -> list[str]:
    if not heatmaps:
        return []
    flagged = sum(h.fallback_cells for h in heatmaps)
    parts = [
        "<h2>Success per robot, arm and object over the swept settings</h2>",
        '<p class="note">Cells: reference successes / rated episodes, rate, valid successes / '
        "judged episodes. Hover a cell for the 95% Wilson intervals, the failures and the "
        f"error rows. {FALLBACK_MARK}: the reference fallback supplied the candidates "
        f"(the filter kept none; dotted frame){f': {flagged} cell(s)' if flagged else ''}.</p>",
    ]
    for robot, maps in groupby(heatmaps, key=lambda h: h.robot):
        parts.append(f"<h3>{html.escape(robot)}</h3>")
        parts.append('<div class="heatmaps">')
        parts += [h.html for h in maps]
        parts.append("</div>")
    return parts


def videos_html(
    run_dir: Path, clips: Sequence[Clip], links: Mapping[str, str] | None = None
) -> list[str]:
    if not clips:
        return []
    esc = html.escape
    parts = [
        "<h2>Videos: one success and one failure per robot arm</h2>",
        '<p class="note">Replayed from the stored rows when the report was built (harness '
        "replay), rendered offscreen with MuJoCo.</p>",
        '<div class="videos">',
    ]
    for clip in clips:
        recording = (links or {}).get(clip.episode_id)
        episode = esc(clip.episode_id)
        if recording:
            episode = f'<a href="{esc(recording)}" title="recording">{episode}</a>'
        caption = (
            f"{clip.robot} · {clip.arm} · {clip.object}: <b>{esc(clip.outcome)}</b><br>"
            f"{episode}, seed {clip.seed}" + (f"<br><i>{esc(clip.note)}</i>" if clip.note else "")
        )
        if clip.path is not None:
            data = base64.b64encode((run_dir / clip.path).read_bytes()).decode("ascii")
            media = (
                f'<video controls muted loop playsinline preload="auto" '
                f'src="data:video/mp4;base64,{data}"></video>'
            )
        else:
            media = "<div>no video</div>"
        parts.append(f"<figure>{media}<figcaption>{caption}</figcaption></figure>")
    parts.append("</div>")
    return parts


def _figure(name: str, path: Path) -> str:
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    caption = html.escape(PLOT_CAPTIONS.get(name, name))
    return (
        f'<figure><img alt="{caption}" src="data:image/png;base64,{data}">'
        f"<figcaption>{caption}</figcaption></figure>"
    )


def render_page(
    run_dir: Path,
    frame: pd.DataFrame,
    tables: list[Table],
    plots: dict[str, Path],
    heatmaps: Sequence[Heatmap] = (),
    clips: Sequence[Clip] = (),
    links: Mapping[str, str] | None = None,
) -> str:
    """The whole page. The static success plot is left out when the heatmaps show it."""
    from plotly.offline import get_plotlyjs  # only when a page is drawn

    esc = html.escape
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>pick-harness report: {esc(run_dir.name)}</title>",
        f"<style>{STYLE}</style>",
        f'<script type="text/javascript">{get_plotlyjs()}</script>' if heatmaps else "",
        "</head><body>",
        f"<h1>pick-harness report: {esc(run_dir.name)}</h1>",
        '<dl class="overview">',
    ]
    parts += [f"<dt>{esc(k)}</dt><dd>{esc(str(v))}</dd>" for k, v in overview(run_dir, frame)]
    parts.append("</dl>")
    parts += heatmaps_html(heatmaps)
    if not heatmaps and "success" in plots:
        parts.append(_figure("success", plots["success"]))
    for table in tables:
        parts += table_html(table)
    parts += videos_html(run_dir, clips, links)
    others = {name: path for name, path in plots.items() if name != "success"}
    if others:
        parts.append('<h2>Plots</h2><div class="plots">')
        parts += [_figure(name, path) for name, path in others.items()]
        parts.append("</div>")
    parts.append(f"<script>{SORTER}</script></body></html>")
    return "\n".join(parts)
