"""Outcome vs placement per robot arm (``plots/placement.png``): where reach ends, from the rows.

One row of panels per robot arm (objects and settings pooled, since the placement of episode k
is the same at every point of a sweep):

- left: every distinct object position in the arm base frame (x forward, y left; the
  ``object_x_m`` / ``object_y_m`` columns; episode k of a sweep has the same placement at every
  point), an outer disc coloured by its reference rate and an inner dot by its valid rate (red 0,
  green 1), a black x where an episode failed for reach (IK at the pre-grasp or grasp); the arm
  base at the origin, rings every 10 cm of distance;
- right: the reference and the valid rate per 5 cm bin of ``object_distance_m`` with their 95%
  Wilson intervals (scipy), so the distance where the rate falls is the arm's reach boundary
  under this task's filters.
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.patches import Circle

from harness.report.frames import column, frame_of
from harness.report.stats import wilson_interval
from harness.report.tables import rated
from harness.writes import write_through

PLACEMENT_COLUMNS = ("object_x_m", "object_y_m", "object_distance_m")
BIN_M = 0.05
KIND_COLOURS = {"valid": "#2da44e", "invalid": "#e3a21a", "failed": "#cf222e"}
DPI = 110


def outcome_kinds(frame: pd.DataFrame) -> pd.Series:
    """valid / invalid / failed per row (``harness.viz.headline.outcome_kind`` on columns)."""
    success = column(frame, "success").astype(bool)
    reason = (
        column(frame, "invalid_reason").fillna("").astype(str)
        if "invalid_reason" in frame
        else pd.Series("", index=frame.index)
    )
    valid = (
        column(frame, "valid").fillna(False).astype(bool)
        if "valid" in frame
        else pd.Series(False, index=frame.index)
    )
    invalid = success & ~valid & ~reason.isin(["", "not_run"])
    kinds = np.where(~success, "failed", np.where(invalid, "invalid", "valid"))
    return pd.Series(kinds, index=frame.index)


def distance_rates(frame: pd.DataFrame, bin_m: float = BIN_M) -> pd.DataFrame:
    """Per distance bin: n, reference and valid successes, rates and Wilson intervals."""
    distance = column(frame, "object_distance_m").to_numpy(dtype=float)
    bins = np.floor(distance / bin_m) * bin_m
    kinds = outcome_kinds(frame).to_numpy(dtype=str)
    rows = []
    for start in np.unique(bins[np.isfinite(bins)]):
        mine = kinds[bins == start]
        n = len(mine)
        reference = int(np.sum(mine != "failed"))
        valid = int(np.sum(mine == "valid"))
        lo, hi = wilson_interval(reference, n)
        vlo, vhi = wilson_interval(valid, n)
        rows.append({"bin_m": float(start), "centre_m": float(start) + bin_m / 2, "n": n,
                     "reference": reference, "valid": valid, "rate": reference / n,
                     "lo": lo, "hi": hi, "valid_rate": valid / n, "valid_lo": vlo,
                     "valid_hi": vhi})  # fmt: skip
    return pd.DataFrame(rows)


def plot_placement(frame: pd.DataFrame, path: Path) -> Path | None:
    """Write the placement figure; None when the rows have no placement columns."""
    if any(name not in frame for name in PLACEMENT_COLUMNS):
        return None
    frame = frame_of(rated(frame))
    frame = frame_of(frame[np.isfinite(column(frame, "object_distance_m").astype(float))])
    if frame.empty:
        return None
    arms = sorted({(str(r), str(a)) for r, a in zip(frame["robot"], frame["arm"], strict=True)})
    fig, axes = plt.subplots(len(arms), 2, figsize=(11, 4.3 * len(arms)), dpi=DPI, squeeze=False)
    limit = float(column(frame, "object_distance_m").max()) * 1.1
    for (robot, arm), (left, right) in zip(arms, axes, strict=True):
        mine = frame_of(frame[(frame["robot"] == robot) & (frame["arm"] == arm)])
        _scatter(left, mine, limit)
        left.set_title(f"{robot} {arm} arm: object at reset (arm base frame)", fontsize=10)
        _rates(right, mine, limit)
        right.set_title(f"{robot} {arm} arm: success vs distance (95% Wilson)", fontsize=10)
    fig.tight_layout()
    try:  # the legends sit below the axes
        write_through(path, lambda tmp: fig.savefig(tmp, bbox_inches="tight"))
    finally:
        plt.close(fig)
    return path


REACH_STAGES = (
    "plan:ik_pregrasp",
    "plan:ik_grasp",
    "feasibility:ik_pregrasp",
    "feasibility:ik_grasp",
)


def placements(frame: pd.DataFrame) -> pd.DataFrame:
    """Per distinct object position (to the mm): n, reference and valid rate, and how many
    episodes failed for reach (IK at the pre-grasp or grasp)."""
    kinds = outcome_kinds(frame).to_numpy(dtype=str)
    stage = (
        column(frame, "failure_stage").fillna("").astype(str).to_numpy(dtype=str)
        if "failure_stage" in frame
        else np.full(len(frame), "")
    )
    x = np.round(column(frame, "object_x_m").to_numpy(dtype=float), 3)
    y = np.round(column(frame, "object_y_m").to_numpy(dtype=float), 3)
    rows = []
    for px, py in dict.fromkeys(zip(x.tolist(), y.tolist(), strict=True)):
        mine = (x == px) & (y == py)
        n = int(mine.sum())
        rows.append({
            "x": px, "y": py, "n": n,
            "rate": float(np.sum(kinds[mine] != "failed")) / n,
            "valid_rate": float(np.sum(kinds[mine] == "valid")) / n,
            "reach": int(np.isin(stage[mine], REACH_STAGES).sum()),
        })  # fmt: skip
    return pd.DataFrame(rows, columns=["x", "y", "n", "rate", "valid_rate", "reach"])


def _scatter(ax: Axes, frame: pd.DataFrame, limit: float) -> None:
    """Each distinct placement: outer disc coloured by the reference rate, inner dot by the
    valid rate (red 0 -> green 1), a black x where some episode failed for reach."""
    table = placements(frame)
    cmap = plt.get_cmap("RdYlGn")
    ax.scatter(table["x"], table["y"], s=70, c=cmap(table["rate"]), edgecolors="#57606a",
               linewidths=0.4)  # fmt: skip
    ax.scatter(table["x"], table["y"], s=16, c=cmap(table["valid_rate"]), edgecolors="none")
    reach_counts = column(table, "reach").to_numpy(dtype=int)
    reach = frame_of(table[reach_counts > 0])
    ax.scatter(reach["x"], reach["y"], s=40, marker="x", c="black", linewidths=1.0)
    for radius in np.arange(0.1, limit + 0.1, 0.1):
        ax.add_patch(Circle((0, 0), float(radius), fill=False, lw=0.5, ls=":", color="#8c959f"))
    ax.plot([0], [0], marker="^", color="black", ms=7)
    ax.set_xlim(0, limit)
    ax.set_ylim(-limit / 2, limit / 2)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("object x (m, forward)")
    ax.set_ylabel("object y (m, left)")
    from matplotlib.lines import Line2D

    def swatch(size: float, label: str, **style: object) -> Line2D:
        return Line2D([], [], ls="", ms=size, label=label, **style)  # type: ignore[arg-type]

    handles = [
        swatch(8, "outer disc: reference rate", marker="o", mfc="#a0a0a0", mec="#57606a"),
        swatch(4, "inner dot: valid rate (red 0, green 1)", marker="o", mfc="#a0a0a0", mec="none"),
        swatch(
            6, f"IK out of reach ({int(np.sum(reach_counts))} episodes)", marker="x", mec="black"
        ),
    ]
    # Below the axes, never over the placements.
    ax.legend(handles=handles, fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.2),
              ncols=2, frameon=False)  # fmt: skip


def _rates(ax: Axes, frame: pd.DataFrame, limit: float) -> None:
    table = distance_rates(frame)
    centre = column(table, "centre_m").to_numpy(dtype=float)
    for prefix, colour, label in (("", "#0969da", "reference"), ("valid_", "#2da44e", "valid")):
        rate = column(table, f"{prefix}rate").to_numpy(dtype=float)
        lo = column(table, f"{prefix}lo").to_numpy(dtype=float)
        hi = column(table, f"{prefix}hi").to_numpy(dtype=float)
        ax.errorbar(centre, rate, yerr=[rate - lo, hi - rate], fmt="o-", ms=4,
                    capsize=3, color=colour, label=f"{label} rate")  # fmt: skip
    for where, n in zip(centre.tolist(), column(table, "n").tolist(), strict=True):
        ax.annotate(f"n={int(n)}", (where, 0.02), fontsize=6, ha="center", color="#57606a")
    low = float(centre.min()) - BIN_M / 2 if len(centre) else 0.0
    ax.set_xlim(max(0.0, low - BIN_M), limit if math.isfinite(limit) else 1.0)
    ax.set_ylim(0, 1.05)
    ax.set_xlabel(f"object distance from the arm base (m, {BIN_M * 100:.0f} cm bins)")
    ax.set_ylabel("success rate")
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.2), ncols=2, frameon=False)
