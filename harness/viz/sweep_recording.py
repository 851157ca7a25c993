"""The Rerun recording of a sweep (rerun-sdk 0.41): ``recording.rrd`` in the run directory, with
the success rate and its Wilson interval per point (one series per task), the summary table, and
one log line per episode.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from harness.markdown import markdown_table
from harness.viz.recording import open_recording, save_recording


def record_sweep(run_dir: Path) -> Path | None:
    """``recording.rrd``: success rate and Wilson interval per point and task, plus a summary."""
    import pandas as pd
    import rerun as rr
    import rerun.blueprint as rrb

    run_dir = Path(run_dir)
    summary_path = run_dir / "summary.csv"
    if not summary_path.is_file():
        return None
    summary = pd.read_csv(summary_path)
    path = run_dir / "recording.rrd"
    rec, stream = open_recording(f"sweep-{run_dir.name}")
    rec.send_blueprint(
        rrb.Blueprint(
            rrb.Horizontal(
                rrb.TimeSeriesView(name="success rate per point", origin="/sweep"),
                rrb.Vertical(
                    rrb.TextDocumentView(name="summary", origin="/summary"),
                    rrb.TextLogView(name="episodes", origin="/episodes"),
                ),
            )
        )
    )
    group_column = "task" if "task" in summary.columns else "robot"
    for group, frame in summary.groupby(group_column, sort=True):
        frame = frame.sort_values("point_id") if "point_id" in frame.columns else frame
        entity = f"/sweep/{str(group).replace('/', '_')}"
        points = (
            frame["point_id"].to_numpy() if "point_id" in frame.columns else np.arange(len(frame))
        )
        values = frame[["rate", "wilson_lo", "wilson_hi"]].to_numpy(dtype=float)
        rec.log(entity, rr.SeriesLines(names=["rate", "wilson_lo", "wilson_hi"]), static=True)
        rec.send_columns(
            entity,
            indexes=[rr.TimeColumn("point", sequence=points.astype(np.int64))],
            columns=rr.Scalars.columns(scalars=values),
        )
    rec.log(
        "/summary",
        rr.TextDocument(_summary_markdown(summary), media_type="text/markdown"),
        static=True,
    )
    episodes_csv = run_dir / "episodes.csv"
    if episodes_csv.is_file():
        episodes = pd.read_csv(episodes_csv)
        # itertuples' rows have the CSV's columns as fields, which the checker cannot know.
        rows: Iterable[Any] = episodes.itertuples(index=False)
        for order, row in enumerate(rows):
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
