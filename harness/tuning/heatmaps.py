"""Tune heatmaps: the success map of one robot, arm and object over approach x facing cones.

Oriented as the screening's report.html heatmap: columns are approach settings (x), rows facing
settings (y, the first at the bottom), each sorted per direction (single angles ascending, then
bands; no filter last); the colour is the objective's screening rate, each cell says k/n when the
grid is small enough to read. The chosen setting is outlined in black, the current one in white
dashes. The title is wrapped to the figure's width, never clipped.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.patches import Rectangle

from harness.files import safe_child
from harness.report.frames import column, frame_of, series_rows
from harness.tuning.analysis import axis_order, filter_label
from harness.writes import output_dir, write_through

ANNOTATE_MAX_CELLS = 400


def _order(table: pd.DataFrame, key: str) -> list[str]:
    """Settings of ``key`` as the map shows them (:func:`harness.tuning.analysis.axis_order`:
    per direction, single angles then bands, no filter last)."""
    return axis_order([str(v) for v in table[key]])


def grid(
    table: pd.DataFrame,
) -> tuple[list[str], list[str], np.ndarray, dict[tuple[int, int], str]]:
    """(approach values: the columns, x; facing values: the rows, y from the bottom; rates
    [row, column]; ``k/n`` per cell), as the page's heatmap lays them out."""
    cols, rows = _order(table, "approach"), _order(table, "facing")
    rates = np.full((len(rows), len(cols)), np.nan)
    counts: dict[tuple[int, int], str] = {}
    for row in series_rows(table):
        i, j = rows.index(str(row["facing"])), cols.index(str(row["approach"]))
        rates[i, j] = float(row["rate"])
        counts[(i, j)] = f"{int(row['successes'])}/{int(row['n'])}"
    return cols, rows, rates, counts


def heatmap(
    table: pd.DataFrame,
    title: str,
    best: tuple[str, str],
    current: tuple[str, str],
    path: Path,
    objective: str = "valid",
) -> Path:
    """Write the heatmap PNG of one success map (``success_map`` rows of one group)."""
    cols, rows, rates, counts = grid(table)
    width = min(22.0, max(7.0, 4.0 + 0.55 * len(cols)))
    height = min(22.0, max(4.5, 3.0 + 0.32 * len(rows)))
    fig, ax = plt.subplots(figsize=(width, height), dpi=100)
    image = ax.imshow(rates, cmap="viridis", vmin=0.0, vmax=1.0, aspect="auto", origin="lower")
    fig.colorbar(image, ax=ax, label=f"{objective} rate")
    ax.set_xticks(range(len(cols)), [filter_label(c) for c in cols], rotation=60, ha="right")
    ax.set_yticks(range(len(rows)), [filter_label(r) for r in rows])
    ax.set_xlabel("approach_filter (angle from base +Z)")
    ax.set_ylabel("facing_filter (facing axis angle from base +X)")
    ax.set_title("\n".join(textwrap.wrap(title, width=int(width * 11))), fontsize=10)
    if rates.size <= ANNOTATE_MAX_CELLS:
        for (i, j), text in counts.items():
            dark = rates[i, j] < 0.6
            ax.text(j, i, text, ha="center", va="center", fontsize=7,
                    color="white" if dark else "black")  # fmt: skip
    for (approach, facing), style in ((current, "--"), (best, "-")):
        if approach in cols and facing in rows:
            i, j = rows.index(facing), cols.index(approach)
            colour = "white" if style == "--" else "black"
            ax.add_patch(Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, lw=2.2,
                                   ls=style, edgecolor=colour))  # fmt: skip
    fig.tight_layout()
    try:
        write_through(path, lambda tmp: fig.savefig(tmp, bbox_inches="tight"))
    finally:
        plt.close(fig)
    return path


def write_heatmaps(
    success: pd.DataFrame,
    decisions: pd.DataFrame,
    out_dir: Path,
    objective: str,
    root: Path | None = None,
) -> dict[tuple[str, str], Path]:
    """One PNG per unit, coloured by the objective's screening rate:
    ``<out_dir>/<robot>_<arm>_<object>.png``; keyed by (task, context)."""
    paths: dict[tuple[str, str], Path] = {}
    output_dir(out_dir, root)  # a planted heatmaps/ link (or one above it): refused
    for row in series_rows(decisions):
        task, context = str(row["task"]), str(row["context"])
        group = frame_of(success[(success["task"] == task) & (success["context"] == context)])
        n = int(column(group, "n").max())
        name = f"{row['robot']} {row['arm']} arm, {row['object']}"
        title = f"{name}: {objective} rate on the screening seeds (n = {n}); {row['verdict']}"
        chosen = (str(row["approach"]), str(row["facing"]))
        current = (str(row["current_approach"]), str(row["current_facing"]))
        path = safe_child(
            out_dir, str(row["robot"]), str(row["arm"]), str(row["object"]), suffix=".png"
        )
        paths[(task, context)] = heatmap(group, title, chosen, current, path, objective)
    return paths
