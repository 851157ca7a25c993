"""Interactive success heatmaps for report.html: one plotly heatmap per robot, arm and object
over the swept settings (never pooled over arms or objects), coloured by the run's objective
(valid by default), each cell with both rates, the objective's first; hovering shows both
Wilson intervals, n, the failures, errors and whether the reference fallback ran. Returned as
HTML fragments without plotly.js (the page embeds it once).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Any, cast

import pandas as pd

from harness.report.frames import column, frame_of, series_rows
from harness.report.labels import format_value, varying_params
from harness.report.objective import VALID
from harness.report.sections import FALLBACK_MARK
from harness.report.tables import FAIL_PREFIX, GROUP_KEY, pooled, setting_params

# The matplotlib plots' scale (red -> yellow -> green), so both read the same.
COLOURSCALE = [[0.0, "#cf222e"], [0.5, "#f2cc60"], [1.0, "#2da44e"]]
CELL_WIDTH, CELL_HEIGHT = 110, 62


@dataclass(frozen=True)
class Heatmap:
    """One robot/arm/object heatmap: its title, element id and HTML fragment."""

    robot: str
    arm: str
    object: str
    div_id: str
    html: str
    fallback_cells: int


def axis_key(value: Any) -> tuple[int, str, list[float], str]:
    """Sort key of one axis value in its axis's own order: numbers ascending; filters
    (``["downward", 140]``, as JSON text) by direction, then single angles ascending before
    bands; anything else by its text. A setting added to a grid (a tune's current setting)
    therefore takes its place among the others instead of coming last."""
    text = str(value)
    try:
        parsed = json.loads(text) if isinstance(value, str) else value
    except (json.JSONDecodeError, TypeError):
        parsed = text
    if isinstance(parsed, bool) or parsed is None:
        return 3, text, [], text
    if isinstance(parsed, (int, float)):
        return 0, "", [float(parsed)], text
    if isinstance(parsed, list) and parsed and isinstance(parsed[0], str):
        angles = [float(a) for a in parsed[1:] if isinstance(a, (int, float))]
        return 1, parsed[0], [float(len(angles)), *angles], text
    return 2, text, [], text


def _axis_values(group: pd.DataFrame, name: str) -> list[Any]:
    values = frame_of(group[[name, "point_id"]]).dropna(subset=[name])
    if pd.api.types.is_numeric_dtype(group[name]):
        return sorted(values[name].unique().tolist())
    return sorted(values[name].drop_duplicates().tolist(), key=axis_key)


def _failures(row: Any) -> str:
    counts = [
        (c.removeprefix(FAIL_PREFIX), int(row[c]))
        for c in row.index
        if str(c).startswith(FAIL_PREFIX) and row[c] > 0
    ]
    counts.sort(key=lambda item: (-item[1], item[0]))
    return ", ".join(f"{reason} {count}" for reason, count in counts) or "none"


def _interval(lo: float, hi: float) -> str:
    return "" if math.isnan(lo) or math.isnan(hi) else f"{lo:.2f}–{hi:.2f}"


def _cell(row: Any, objective: str = VALID) -> tuple[float | None, str, str]:
    """(colour value, cell text, hover text) of one pooled summary row: coloured by the
    objective's rate, its count first, the other verdict's count beside it."""
    n, k = int(row["n"]), int(row["successes"])
    judged = int(row.get("n_judged", 0) or 0)
    fallback, errors = int(row.get("fallback", 0) or 0), int(row.get("errors", 0) or 0)
    rate = k / n if n else None
    valid_rate = int(row["valid"]) / judged if judged else None
    reference_text = f"reference {k}/{n}"
    valid_text = f"valid {int(row['valid'])}/{judged}" if judged else ""
    if objective == VALID:
        value = valid_rate
        text = valid_text or "valid: not judged"
        text += f"<br>{valid_rate:.0%}" if valid_rate is not None else ""
        text += f"<br>{reference_text}"
    else:
        value = rate
        text = f"{k}/{n}" + (f"<br>{rate:.0%}" if rate is not None else "")
        text += f"<br>{valid_text}" if valid_text else ""
    if fallback:
        text += f" {FALLBACK_MARK}"
    if errors:
        text += f"<br>+{errors} error{'s' if errors > 1 else ''}"
    hover = [
        f"colour: {objective} rate",
        reference_text + (f" = {rate:.0%}" if rate is not None else ""),
        f"95% CI {_interval(row['wilson_lo'], row['wilson_hi'])}" if n else "no rated episodes",
    ]
    if judged:
        hover.append(
            f"valid {int(row['valid'])}/{judged} = {row['valid_rate']:.0%}, 95% CI "
            f"{_interval(row['valid_ci_low'], row['valid_ci_high'])}"
        )
    hover.append(f"failures: {_failures(row)}")
    if errors:
        hover.append(f"error rows (not in the rate): {errors}")
    if fallback:
        hover.append(f"{FALLBACK_MARK} reference fallback ran in {fallback}/{n} episodes")
    return value, text, "<br>".join(hover)


def _figure(
    group: pd.DataFrame, axes: list[str], title: str, objective: str = VALID
) -> tuple[Any, int]:
    import plotly.graph_objects as go  # ~0.5 s: only when a page is drawn

    x_axis = axes[0] if axes else None
    y_axis = axes[1] if len(axes) > 1 else None
    cells = pooled(group, [a for a in (x_axis, y_axis) if a] or ["robot"])
    x_values = _axis_values(group, x_axis) if x_axis else ["default"]
    y_values = _axis_values(group, y_axis) if y_axis else [""]
    z: list[list[float | None]] = [[None] * len(x_values) for _ in y_values]
    text = [["not run"] * len(x_values) for _ in y_values]
    hover = [["not run"] * len(x_values) for _ in y_values]
    flagged: list[tuple[int, int]] = []
    for row in series_rows(cells):
        i = y_values.index(row[y_axis]) if y_axis else 0
        j = x_values.index(row[x_axis]) if x_axis else 0
        z[i][j], text[i][j], hover[i][j] = _cell(row, objective)
        if row.get("fallback", 0):
            flagged.append((i, j))
    figure = go.Figure(
        go.Heatmap(
            z=z,
            x=[format_value(v) for v in x_values],
            y=[format_value(v) for v in y_values],
            text=text,
            texttemplate="%{text}",
            customdata=hover,
            hovertemplate="%{customdata}<extra></extra>",
            colorscale=COLOURSCALE,
            zmin=0.0,
            zmax=1.0,
            showscale=False,
            xgap=2,
            ygap=2,
        )
    )
    pooled_over = [a.removeprefix("param.") for a in axes[2:]]
    subtitle = f" (pooled over {', '.join(pooled_over)})" if pooled_over else ""
    figure.update_layout(
        title={"text": title + subtitle, "font": {"size": 14}},
        width=max(280, (140 if y_axis else 50) + CELL_WIDTH * len(x_values)),
        height=max(190, 120 + CELL_HEIGHT * len(y_values)),
        margin={"l": 110 if y_axis else 20, "r": 20, "t": 45, "b": 60},
        xaxis={"title": x_axis.split(".")[-1] if x_axis else "", "type": "category"},
        yaxis={"title": y_axis.split(".")[-1] if y_axis else "", "type": "category"},
        plot_bgcolor="#eaeef2",
    )
    # A dotted frame where the reference fallback ran; set at once (``add_shape`` one by one
    # validates the whole growing list again each time: ~0.3 s for a grid's 69 frames).
    frame_line = {"color": "#1f2328", "width": 3, "dash": "dot"}
    figure.layout.shapes = [
        go.layout.Shape(
            type="rect", x0=j - 0.5, x1=j + 0.5, y0=i - 0.5, y1=i + 0.5, line=frame_line
        )
        for i, j in flagged
    ]
    return figure, len(flagged)


def success_heatmaps(summary: pd.DataFrame, objective: str = VALID) -> list[Heatmap]:
    """One heatmap per robot, arm and object over its swept settings (summary rows of a run),
    coloured by the objective's rate (``harness.report.objective``)."""
    settings = setting_params(summary) or varying_params(summary)
    out: list[Heatmap] = []
    for key, group in summary.groupby(GROUP_KEY, sort=True):
        robot, arm, obj = (str(part) for part in cast(tuple[Any, ...], key))
        group = frame_of(group)
        axes = [a for a in settings if column(group, a).nunique(dropna=True) > 1] or settings[:1]
        figure, fallback_cells = _figure(group, axes, f"{robot} · {arm} · {obj}", objective)
        div_id = f"heatmap-{robot}-{arm}-{obj}".replace(" ", "_")
        html = figure.to_html(
            full_html=False,
            include_plotlyjs=False,
            div_id=div_id,
            config={"displayModeBar": False, "responsive": False},
        )
        out.append(Heatmap(robot, arm, obj, div_id, html, fallback_cells))
    return out
