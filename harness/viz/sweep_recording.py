"""The Rerun recording of a sweep (rerun-sdk 0.41): ``recording.rrd`` in the run directory. It
opens on the comparison (``harness.viz.sweep_comparison``: per robot, arm and object one view,
one named series per setting, on the ``episode`` timeline); the overview tab holds the success
rate and its Wilson interval per point (one series per robot, arm and object, so
points of different objects never interleave into a zig-zag), the valid rate beside it, the
summary table, and one log line per episode -- all on the ``point`` timeline. The time panel
opens on the timeline that holds the first tab's data (the viewer would otherwise open an empty
one): ``episode``, or ``point`` for a run without episodes.csv.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from harness.markdown import markdown_table
from harness.viz.recording import open_recording, save_recording
from harness.viz.sweep_comparison import TIMELINE as COMPARE_TIMELINE
from harness.viz.sweep_comparison import comparison_units, comparison_views, log_comparison


def record_sweep(run_dir: Path, objective: str = "valid") -> Path | None:
    """``recording.rrd``: the settings compared per robot, arm and object (running ``objective``
    rate, one named series per setting: ``harness.viz.sweep_comparison``), and the overview:
    success rate and Wilson interval per point and task, the summary, the episodes."""
    import pandas as pd
    import rerun as rr

    run_dir = Path(run_dir)
    summary_path = run_dir / "summary.csv"
    if not summary_path.is_file():
        return None
    summary = pd.read_csv(summary_path)
    episodes_csv = run_dir / "episodes.csv"
    episodes = pd.read_csv(episodes_csv) if episodes_csv.is_file() else None
    units = comparison_units(episodes, objective) if episodes is not None else []
    path = run_dir / "recording.rrd"
    rec, stream = open_recording(f"sweep-{run_dir.name}")
    rec.send_blueprint(_blueprint(units))
    log_comparison(rec, units)
    for entity, frame in series_groups(summary):
        points = (
            frame["point_id"].to_numpy() if "point_id" in frame.columns else np.arange(len(frame))
        )
        columns = [c for c in SERIES_COLUMNS if c in frame.columns]
        values = frame[columns].to_numpy(dtype=float)
        unit = entity.removeprefix("/sweep/").replace("/", " ")
        names = [f"{unit}: {SERIES_NAMES[c]}" for c in columns]
        rec.log(entity, rr.SeriesLines(names=names), static=True)
        rec.send_columns(
            entity,
            indexes=[rr.TimeColumn(TIMELINE, sequence=points.astype(np.int64))],
            columns=rr.Scalars.columns(scalars=values),
        )
    rec.log(
        "/summary",
        rr.TextDocument(_summary_markdown(summary), media_type="text/markdown"),
        static=True,
    )
    if episodes is not None:
        # itertuples' rows have the CSV's columns as fields, which the checker cannot know.
        rows: Iterable[Any] = episodes.itertuples(index=False)
        for order, row in enumerate(rows):
            rec.set_time(TIMELINE, sequence=int(getattr(row, "point_id", 0)))
            rec.set_time("episode", sequence=order)
            ok = bool(getattr(row, "success", False))
            reason = getattr(row, "failure_reason", "")
            reason = "" if (isinstance(reason, float) and np.isnan(reason)) else reason
            text = (
                f"{row.episode_id}: {'success' if ok else 'failure ' + str(reason)}"
                f" point {getattr(row, 'point', '')}"
            )
            level = rr.TextLogLevel.INFO if ok else rr.TextLogLevel.WARN
            rec.log("/episodes", rr.TextLog(text, level=level))
    return save_recording(rec, stream, path)


def _blueprint(units: list[Any]) -> Any:
    """Opens on the comparison (one view per robot, arm and object, on the ``episode``
    timeline) when there are episodes; the per-point overview is the other tab."""
    import rerun.blueprint as rrb

    overview = rrb.Horizontal(
        rrb.TimeSeriesView(name="success rate per point", origin="/sweep"),
        rrb.Vertical(
            rrb.TextDocumentView(name="summary", origin="/summary"),
            rrb.TextLogView(name="episodes", origin="/episodes"),
        ),
        name="overview per point",
    )
    if not units:
        return rrb.Blueprint(overview, rrb.TimePanel(timeline=TIMELINE))
    compare = rrb.Grid(*comparison_views(units), name="compare settings")
    return rrb.Blueprint(
        rrb.Tabs(compare, overview, active_tab=0), rrb.TimePanel(timeline=COMPARE_TIMELINE)
    )


TIMELINE = "point"
SERIES_COLUMNS = ("rate", "wilson_lo", "wilson_hi", "valid_rate")
SERIES_NAMES = {
    "rate": "reference rate",
    "wilson_lo": "95% low",
    "wilson_hi": "95% high",
    "valid_rate": "valid rate",
}
SERIES_KEYS = ("robot", "arm", "object")


def series_groups(summary: Any) -> list[tuple[str, Any]]:
    """(entity, rows sorted by point) per robot, arm and object: one monotonic series each."""
    keys = [k for k in SERIES_KEYS if k in summary.columns] or ["task"]
    out = []
    for group, frame in summary.groupby(keys, sort=True):
        values = group if isinstance(group, tuple) else (group,)
        entity = "/sweep/" + "/".join(str(v).replace("/", "_") or "_" for v in values)
        if "point_id" in frame.columns:
            frame = frame.sort_values("point_id", kind="stable")
        out.append((entity, frame))
    return out


def _summary_markdown(summary: Any) -> str:
    columns = [
        c
        for c in (
            "task",
            "robot",
            "arm",
            "object",
            "point",
            "n",
            "successes",
            "rate",
            "wilson_lo",
            "wilson_hi",
        )
        if c in summary.columns
    ]
    columns += [c for c in summary.columns if c.startswith("param.") and c not in columns]
    rows = [
        [f"{v:.3f}" if isinstance(v, float) else str(v) for v in row.tolist()]
        for _, row in summary[columns].iterrows()
    ]
    lines = markdown_table(columns, rows)
    return "# Sweep summary\n\n" + "\n".join(lines)


def point_label(point: Any) -> str:
    if isinstance(point, str):
        try:
            point = json.loads(point)
        except json.JSONDecodeError:
            return point
    return ", ".join(f"{k}={v}" for k, v in dict(point).items()) or "default"
