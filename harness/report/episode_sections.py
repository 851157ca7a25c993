"""The report's tables of single episodes: error rows, grouped failure messages and example
episodes, each episode id linked to its recording (``episodes/*.rrd`` in the run directory)
when one was written, and every seed printed in full (a seed is what reproduces an episode).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pandas as pd

from harness.report.frames import column, frame_of, series_rows
from harness.report.labels import point_label
from harness.report.sections import Table
from harness.report.tables import rated

MAX_EXAMPLE_IDS = 3
MAX_GROUPS = 30
MESSAGE_CHARS = 240


def recording_links(run_dir: Path, frame: pd.DataFrame) -> dict[str, str]:
    """``episode_id -> recording`` (relative to the run directory) for recordings that exist."""
    if "recording" not in frame:
        return {}
    links: dict[str, str] = {}
    for episode, recording in zip(frame["episode_id"], frame["recording"], strict=True):
        text = "" if recording is None or pd.isna(recording) else str(recording)
        if text and (run_dir / text).is_file():
            links[str(episode)] = text
    return links


def full_seed(value: Any) -> str:
    """A seed as the integer it is: all its digits (a cut seed reproduces nothing)."""
    if value is None or pd.isna(value):
        return ""
    return str(int(value))


def _linked(ids: list[str], links: dict[str, str]) -> list[tuple[str, str | None]]:
    return [(episode, links.get(episode)) for episode in ids]


def errors_table(errors: pd.DataFrame, params: list[str], links: dict[str, str]) -> Table:
    """The ``error`` rows with their messages (they are in no rate)."""
    rows, cell_links = [], {}
    for i, r in enumerate(series_rows(errors)):
        point = _point_cells(r, params)
        rows.append(
            [
                str(r["robot"]),
                str(r["arm"]),
                str(r["object"]),
                point,
                str(r["episode_id"]),
                full_seed(r.get("seed")),
                str(r.get("error_message", ""))[:MESSAGE_CHARS],
            ]
        )
        cell_links[(i, 4)] = _linked([str(r["episode_id"])], links)
    return Table(
        "Error rows (left out of every rate)",
        ["robot", "arm", "object", "setting", "episode", "seed", "message"],
        rows,
        "Episodes that ended in an error (a crashed worker, bad input) rather than a verdict. "
        "`harness sweep --resume RUN_DIR --retry-errors` runs them again.",
        links=cell_links,
    )


def _point_cells(row: Any, params: list[str]) -> str:
    present = [p for p in params if p in row.index]
    return point_label(row, present)


def failure_groups_table(groups: pd.DataFrame, links: dict[str, str]) -> Table:
    """Failure messages grouped per robot and arm (columns of ``group_failures``: robot, arm,
    failure_reason, message_pattern, count, example_episode_ids)."""
    rows, cell_links = [], {}
    shown = frame_of(groups.head(MAX_GROUPS))
    for i, r in enumerate(series_rows(shown)):
        examples = [str(e) for e in list(r["example_episode_ids"])[:MAX_EXAMPLE_IDS]]
        rows.append(
            [
                str(r["robot"]),
                str(r["arm"]),
                str(r["failure_reason"]),
                str(r["message_pattern"])[:MESSAGE_CHARS],
                str(int(r["count"])),
                ", ".join(examples),
            ]
        )
        cell_links[(i, 5)] = _linked(examples, links)
    note = f"The {len(shown)} largest of {len(groups)} groups." if len(groups) > len(shown) else ""
    return Table(
        "Failure messages, grouped",
        ["robot", "arm", "reason", "message", "episodes", "example episodes"],
        rows,
        (note + " Example episodes link to their recording when one was written.").strip(),
        links=cell_links,
    )


def examples_table(frame: pd.DataFrame, params: list[str], links: dict[str, str]) -> Table:
    """Per robot, arm and object: the first success and the first failure, with full seeds."""
    frame = rated(frame)
    order = [c for c in ("point_id", "episode_index") if c in frame]
    frame = frame_of(frame.sort_values(order, kind="stable")) if order else frame
    rows, cell_links = [], {}
    for _, group in frame.groupby(["robot", "arm", "object"], sort=True):
        for outcome, mask in (("success", True), ("failure", False)):
            picked = frame_of(group.loc[column(group, "success").astype(bool) == mask])
            if picked.empty:
                continue
            r = picked.iloc[0]
            episode = str(r["episode_id"])
            reason = "" if mask else str(r["failure_reason"])
            cell_links[(len(rows), 5)] = _linked([episode], links)
            rows.append(
                [
                    str(r["robot"]),
                    str(r["arm"]),
                    str(r["object"]),
                    _point_cells(r, params),
                    f"{outcome} {reason}".strip(),
                    episode,
                    full_seed(r["seed"]),
                ]
            )
    return Table(
        "Example episodes",
        ["robot", "arm", "object", "setting", "outcome", "episode", "seed"],
        rows,
        "Any episode runs again from its row: `harness replay RUN_DIR EPISODE_ID --video "
        "out.mp4 --record out.rrd`. Linked ids open their recording.",
        links=cell_links,
    )
