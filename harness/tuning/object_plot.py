"""The picture of a template decision: every object's rate under the current and the chosen
template (``tune/objects_<group>.png``), sorted by the template's rate, exceptions marked."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from harness.report.frames import frame_of, series_rows
from harness.writes import output_dir, write_through


def object_plot(objects: pd.DataFrame, group: str, title: str, path: Path) -> Path:
    """A dumbbell per object: the current template's rate (grey) to the chosen one's (blue) on
    the race's fresh seeds; an override in green, no setting helps in red."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = frame_of(objects[objects["group"] == group]).sort_values(
        "template_rate", ascending=True, kind="stable"
    )
    height = max(2.5, 0.28 * len(rows) + 1.2)
    fig, ax = plt.subplots(figsize=(7.5, height))
    for i, row in enumerate(series_rows(rows)):
        current, chosen = float(row["current_rate"]), float(row["template_rate"])
        ax.plot([current, chosen], [i, i], color="#bbbbbb", lw=2, zorder=1)
        ax.scatter([current], [i], color="#888888", s=28, zorder=2)
        colour = "#1f77b4"
        if row["exception"] == "override":
            colour = "#2ca02c"
        elif bool(row["no_setting_helps"]):
            colour = "#d62728"
        ax.scatter([chosen], [i], color=colour, s=36, zorder=3)
    ax.set_yticks(range(len(rows)))
    labels = [
        f"{r['object']}" + (" (override)" if r["exception"] == "override" else "")
        for r in series_rows(rows)
    ]
    ax.set_yticklabels(labels, fontsize=8)
    ax.set_xlim(-0.03, 1.03)
    ax.set_xlabel("rate on the race's fresh seeds (grey: current template, blue: chosen)")
    ax.set_title(title, fontsize=9, loc="left")
    ax.grid(axis="x", alpha=0.3)
    fig.tight_layout()
    output_dir(path.parent)
    try:
        write_through(path, lambda tmp: fig.savefig(tmp, dpi=110, format="png"))
    finally:
        plt.close(fig)
    return path
