"""The report's plots (matplotlib, Agg backend): success over the swept axes, outcomes per
point, and the candidate funnel. Each function writes one PNG and returns its path.
"""

from __future__ import annotations

from pathlib import Path
from typing import cast

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.cm import ScalarMappable
from matplotlib.colors import LinearSegmentedColormap, Normalize
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter

from harness.report.frames import column, frame_of, series_of, series_rows, tuple_rows
from harness.report.labels import format_value, point_label, varying_params
from harness.report.tables import FAIL_PREFIX, pooled, setting_params
from harness.writes import write_through

DPI = 110
MAX_BARS = 60
SUCCESS_COLOUR = "#2da44e"
# One fixed colour per failure reason, so plots of different runs read the same way.
REASON_COLOURS: dict[str, str] = {
    "filter_empty": "#8c959f",
    "no_feasible_candidate": "#bf8700",
    "plan_failed": "#e16f24",
    "collision": "#cf222e",
    "no_contact": "#8250df",
    "dropped": "#bc4c00",
    "lift_below_threshold": "#d4a72c",
    "velocity_invalid": "#a40e26",
    "sim_unstable": "#1b7c83",
    "timeout": "#0969da",
    "error": "#24292f",
    "unknown": "#d0d7de",
}
RATE_CMAP = LinearSegmentedColormap.from_list("rate", ["#cf222e", "#f2cc60", "#2da44e"])


def _axis_order(summary: pd.DataFrame, column: str) -> list:
    """Values of a parameter axis: numeric ascending, otherwise in sweep (point) order."""
    values = frame_of(summary[[column, "point_id"]]).dropna(subset=[column])
    if pd.api.types.is_numeric_dtype(summary[column]):
        return sorted(values[column].unique().tolist())
    first_seen = series_of(values.groupby(column, sort=False)["point_id"].min())
    first_seen = first_seen.sort_values(kind="stable")
    return first_seen.index.tolist()


def _save(fig: Figure, path: Path) -> Path:
    """Write ``fig`` as ``savefig(path, dpi=DPI, bbox_inches="tight")`` does, with one pass less.

    For a tight bbox savefig first draws the whole figure without output (every artist, every
    text laid out) only to measure it, then renders it. Here the layout engine runs once and the
    bbox is measured directly (``get_tightbbox``: the texts' extents only), then savefig renders
    once into that bbox, its layout turned off as savefig turns it off for its own render. The
    PNG is byte for byte savefig's; the pass saved was ~0.3 s of a 342-setting sweep's report
    (its three plots)."""
    fig.set_dpi(DPI)
    renderer = cast(FigureCanvasAgg, fig.canvas).get_renderer()
    engine = fig.get_layout_engine()
    if engine is not None:
        engine.execute(fig)
        fig.set_layout_engine(None)  # laid out: savefig would otherwise draw it once more
    box = fig.get_tightbbox(renderer).padded(matplotlib.rcParams["savefig.pad_inches"])
    try:
        write_through(path, lambda tmp: fig.savefig(tmp, dpi=DPI, bbox_inches=box))
    finally:
        plt.close(fig)
    return path


def _grid(count: int, width: float, height: float) -> tuple[Figure, list[Axes]]:
    cols = min(3, count)
    rows = -(-count // cols)
    fig, axes = plt.subplots(
        rows, cols, figsize=(width * cols, height * rows), squeeze=False, layout="constrained"
    )
    flat = list(axes.ravel())
    for extra in flat[count:]:
        extra.set_visible(False)
    return fig, flat[:count]


# --------------------------------------------------------------------------------------------
# Success


def plot_success(summary: pd.DataFrame, path: Path, objective: str = "reference") -> Path:
    """Per robot, a heatmap with one row per arm and object (and value of a second swept
    setting) over the first swept setting, coloured by the objective's rate; arms and objects
    are never pooled. Without a swept setting: bars per robot, arm and object."""
    axes = setting_params(summary) or varying_params(summary)
    if axes:
        second = axes[1] if len(axes) > 1 else None
        return _success_heatmap(summary, axes[0], second, path, objective)
    return _success_per_task(summary, path)


def _row_label(row: pd.Series, y_axis: str | None) -> str:
    label = f"{row['arm']} · {row['object']}"
    return label + (f" · {format_value(row[y_axis])}" if y_axis else "")


# The most cells of one robot's heatmap that carry their counts as text. Chosen, no public
# source: a tune's refine pass (4,000 points) drew ~4,000 texts into a 10,347 x 5,611 px PNG
# (8 MB) that took 20 s to render on 2 cores and could not be read at any zoom; past this the
# cells are colour only and the counts stay in summary.csv and the page's tables.
MAX_LABELLED_CELLS = 400


def _success_heatmap(
    summary: pd.DataFrame, x_axis: str, y_axis: str | None, path: Path, objective: str
) -> Path:
    robots = sorted(summary["robot"].unique())
    x_values = _axis_order(summary, x_axis)
    by = ["arm", "object", *([y_axis] if y_axis else []), x_axis]
    row_counts = [len(pooled(frame_of(summary[summary["robot"] == r]), by[:-1])) for r in robots]
    cell_width = max(1.0, max(len(format_value(v)) for v in x_values) * 0.09)
    width = 2.6 + cell_width * len(x_values)
    labelled = max(row_counts) * len(x_values) <= MAX_LABELLED_CELLS
    if not labelled:  # colour only: small cells
        cell_width = min(cell_width, 0.25)
        width = 2.6 + cell_width * len(x_values)
    row_height = 0.62 if labelled else 0.12
    fig, axes = _grid(len(robots), max(width, 4.0), 1.3 + row_height * max(row_counts))
    for ax, robot in zip(axes, robots, strict=True):
        cells = pooled(frame_of(summary[summary["robot"] == robot]), by)
        rows = pooled(frame_of(summary[summary["robot"] == robot]), by[:-1])
        labels = [_row_label(r, y_axis) for r in series_rows(rows)]
        rate = np.full((len(labels), len(x_values)), np.nan)
        texts: dict[tuple[int, int], str] = {}
        for values in series_rows(cells):
            i = labels.index(_row_label(values, y_axis))
            j = x_values.index(values[x_axis])
            judged = int(values.get("n_judged", 0) or 0)
            reference = f"{int(values['successes'])}/{int(values['n'])}"
            valid = f"valid {int(values['valid'])}/{judged}" if judged else ""
            if objective == "valid":
                rate[i, j] = values["valid_rate"] if judged else np.nan
                text = f"{valid}\nref {reference}" if judged else f"ref {reference}"
            else:
                rate[i, j] = values["rate"]
                text = reference + (f"\n{valid}" if valid else "")
            texts[(i, j)] = text + (" *" if values.get("fallback", 0) else "")
        ax.imshow(np.ma.masked_invalid(rate), cmap=RATE_CMAP, vmin=0.0, vmax=1.0, aspect="auto")
        ax.set_facecolor("#eaeef2")
        for (i, j), text in texts.items() if labelled else ():
            value = rate[i, j]
            dark = not np.isnan(value) and (value < 0.25 or value > 0.8)
            # Inside the axes (clipped to it): left out of the layout, which would measure
            # every cell's text for nothing.
            ax.text(j, i, text, ha="center", va="center", fontsize=7.5,
                    color="white" if dark else "#1f2328", in_layout=False)  # fmt: skip
        ax.set_xticks(
            range(len(x_values)), [format_value(v) for v in x_values], fontsize=8 if labelled else 5
        )
        ax.set_yticks(range(len(labels)), labels, fontsize=8 if labelled else 5)
        ax.set_xlabel(x_axis.split(".")[-1], fontsize=9)
        ax.set_title(robot, fontsize=11, fontweight="bold")
        turn = 30 if cell_width > 1.0 else 0
        plt.setp(ax.get_xticklabels(), rotation=turn if labelled else 90, ha="right")
    cells = "valid, reference" if objective == "valid" else "reference, valid"
    legend = (
        f"cells: {cells} successes/episodes; * reference fallback ran"
        if labelled
        else f"colour only: over {MAX_LABELLED_CELLS} cells a robot; counts in summary.csv"
    )
    fig.suptitle(f"{objective.capitalize()} rate per robot, arm and object ({legend})", fontsize=10)
    mappable = ScalarMappable(cmap=RATE_CMAP, norm=Normalize(0, 1))
    fig.colorbar(mappable, ax=axes, shrink=0.8, label=f"{objective} rate", format="{x:.0%}")
    return _save(fig, path)


def _bars_with_ci(
    ax: Axes, positions: np.ndarray, table: pd.DataFrame, width: float, colour: str, label: str
) -> None:
    rates = table["rate"].to_numpy(dtype=float)
    lower = np.clip(rates - table["wilson_lo"].to_numpy(dtype=float), 0, None)
    upper = np.clip(table["wilson_hi"].to_numpy(dtype=float) - rates, 0, None)
    ax.bar(positions, rates, width, color=colour, label=label, edgecolor="white")
    ax.errorbar(
        positions,
        rates,
        yerr=np.vstack([lower, upper]),
        fmt="none",
        ecolor="#24292f",
        capsize=3,
        linewidth=1,
    )
    for x, hi, k, n in zip(
        positions, table["wilson_hi"], table["successes"], table["n"], strict=True
    ):
        ax.text(x, hi + 0.02, f"{int(k)}/{int(n)}", ha="center", va="bottom", fontsize=7.5)


def _robot_colours(robots: list[str]) -> dict[str, str]:
    palette = ["#0969da", "#8250df", "#bf3989", "#1b7c83", "#bc4c00", "#57606a"]
    return {robot: palette[i % len(palette)] for i, robot in enumerate(robots)}


def _success_per_task(summary: pd.DataFrame, path: Path) -> Path:
    table = pooled(summary, ["robot", "arm", "object"])
    table = table.sort_values(["robot", "arm", "object"]).reset_index(drop=True)
    colours = _robot_colours(sorted(table["robot"].unique()))
    fig, ax = plt.subplots(figsize=(max(5.0, 1.0 + 0.9 * len(table)), 4.2))
    positions = np.arange(len(table), dtype=float)
    for robot, rows in table.groupby("robot", sort=True):
        name = cast(str, robot)
        _bars_with_ci(ax, positions[rows.index], rows, 0.7, colours[name], name)
    ax.set_xticks(
        positions, [f"{r.robot}\n{r.arm} · {r.object}" for r in tuple_rows(table)], fontsize=8
    )
    _rate_axis(ax)
    ax.set_title("Success rate with 95% Wilson interval")
    return _save(fig, path)


def _rate_axis(ax: Axes) -> None:
    ax.set_ylim(0, 1.12)
    ax.set_yticks(np.linspace(0, 1, 6))
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:.0%}"))
    ax.set_ylabel("success rate")
    ax.grid(axis="y", color="#eaeef2")
    ax.set_axisbelow(True)
    for side in ("top", "right"):
        ax.spines[side].set_visible(False)


# --------------------------------------------------------------------------------------------
# Outcomes per point


def _outcome_rows(summary: pd.DataFrame) -> tuple[pd.DataFrame, list[str], str]:
    """Summary rows to draw (pooled coarser when there are too many) and their labels."""
    params = setting_params(summary) or varying_params(summary)
    levels = (
        (["robot", "arm", "object", "task", "point"], "per task and point"),
        (["robot", "point"], "per robot and point, pooled over arms and objects"),
        (["point"], "per point, pooled over robots"),
    )
    table, note_text = summary, levels[0][1]
    for keys, level_note in levels:
        table = summary if len(keys) == 5 else pooled(summary, keys)
        note_text = level_note
        if len(table) <= MAX_BARS:
            break
    if len(table) > MAX_BARS:
        table = table.sort_values("point_id").head(MAX_BARS)
        note_text += f"; first {MAX_BARS} points"
    labels = []
    for _, row in table.iterrows():
        head = [str(row[k]) for k in ("robot", "arm", "object") if k in table.columns]
        labels.append(" · ".join(head) + (" | " if head else "") + point_label(row, params))
    return table.reset_index(drop=True), labels, note_text


INVALID_COLOUR = "#e3a21a"  # a reference success that is not valid (the report's orange)


def plot_failures(summary: pd.DataFrame, path: Path, objective: str = "reference") -> Path:
    """Horizontal stacked bars: successes and each failure reason, per point. Under the
    ``valid`` objective the successes split into valid ones and reference successes that are
    not valid, so the green bar is the objective's count."""
    table, labels, note = _outcome_rows(summary)
    reasons = [
        c.removeprefix(FAIL_PREFIX)
        for c in table.columns
        if c.startswith(FAIL_PREFIX) and column(table, c).sum() > 0
    ]
    height = 1.6 + 0.32 * len(table)
    longest = max(len(label) for label in labels)
    fig, ax = plt.subplots(figsize=(6.5 + 0.055 * longest, height))
    y = np.arange(len(table))[::-1]
    left = np.zeros(len(table))
    successes = table["successes"].to_numpy(dtype=float)
    segments = [("success", successes, SUCCESS_COLOUR)]
    if objective == "valid" and "valid" in table and column(table, "n_judged").sum() > 0:
        valid = table["valid"].to_numpy(dtype=float)
        segments = [
            ("valid", valid, SUCCESS_COLOUR),
            ("reference success, not valid", np.clip(successes - valid, 0, None), INVALID_COLOUR),
        ]
    segments += [
        (reason, table[FAIL_PREFIX + reason].to_numpy(dtype=float), REASON_COLOURS.get(reason))
        for reason in reasons
    ]
    for name, counts, colour in segments:
        ax.barh(
            y,
            counts,
            left=left,
            color=colour or "#6e7781",
            label=name,
            edgecolor="white",
            height=0.75,
        )
        for yi, start, count in zip(y, left, counts, strict=True):
            if count > 0 and count / max(column(table, "n").max(), 1) > 0.06:
                ax.text(
                    start + count / 2,
                    yi,
                    str(int(count)),
                    ha="center",
                    va="center",
                    fontsize=7,
                    color="white",
                )
        left += counts
    ax.set_yticks(y, labels, fontsize=8)
    ax.set_xlabel("episodes")
    ax.set_xlim(0, left.max() * 1.02 if left.max() else 1)
    for side in ("top", "right"):
        ax.spines[side].set_visible(False)
    ax.legend(
        frameon=False,
        fontsize=8,
        ncols=min(len(segments), 4),
        loc="lower left",
        bbox_to_anchor=(0, 1.0),
    )
    ax.set_title(f"Outcomes {note}", fontsize=10, pad=28 + 12 * ((len(segments) - 1) // 4))
    return _save(fig, path)


# --------------------------------------------------------------------------------------------
# Funnel


def plot_funnel(stages: pd.DataFrame, path: Path) -> Path:
    """Left: candidate sums per stage (log scale); right: share of episodes reaching a stage."""
    if stages.empty:  # every row an error: nothing reached any stage
        fig, ax = plt.subplots(figsize=(6, 1.5))
        ax.axis("off")
        ax.text(0.5, 0.5, "no rated episodes (every row is an error)", ha="center", va="center")
        return _save(fig, path)
    robots = stages["robot"].tolist()
    colours = _robot_colours(robots)
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2))
    names = ["candidates", "passed filter", "tested", "feasible"]
    columns = [
        "candidates_total",
        "candidates_passed_filter",
        "candidates_tested",
        "candidates_feasible",
    ]
    width = 0.8 / max(len(robots), 1)
    for index, row in enumerate(series_rows(stages.reset_index(drop=True))):
        values = row[columns].to_numpy(dtype=float)
        positions = np.arange(len(names)) + (index - (len(robots) - 1) / 2) * width
        bars = left.bar(
            positions,
            np.maximum(values, 0.8),
            width * 0.92,
            color=colours[row["robot"]],
            label=row["robot"],
        )
        for bar, value in zip(bars, values, strict=True):
            left.text(
                bar.get_x() + bar.get_width() / 2,
                max(value, 0.8) * 1.15,
                f"{int(value):,}",
                ha="center",
                va="bottom",
                fontsize=7,
                rotation=90,
            )
    left.set_yscale("log")
    left.set_ylim(0.7, max(stages[columns].to_numpy().max(), 1) * 30)
    left.set_xticks(range(len(names)), names)
    left.set_ylabel("candidates (sum over episodes)")
    left.set_title("Candidate funnel")
    left.legend(frameon=False, fontsize=8)

    shares = ["episodes_filter_ok", "episodes_feasible", "episodes_success"]
    share_names = ["filter kept\ncandidates", "feasible\ncandidate", "success"]
    for index, row in enumerate(series_rows(stages.reset_index(drop=True))):
        values = row[shares].to_numpy(dtype=float)
        positions = np.arange(len(shares)) + (index - (len(robots) - 1) / 2) * width
        right.bar(positions, values, width * 0.92, color=colours[row["robot"]])
        for x, value in zip(positions, values, strict=True):
            right.text(x, value + 0.02, f"{value:.0%}", ha="center", va="bottom", fontsize=7)
    right.set_xticks(range(len(shares)), share_names)
    _rate_axis(right)
    right.set_ylabel("share of episodes")
    right.set_title("Episodes reaching each stage")
    for side in ("top", "right"):
        left.spines[side].set_visible(False)
    return _save(fig, path)
