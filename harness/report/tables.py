"""The run's data tables: its episodes, and per-point summaries, best settings, failure counts,
the candidate funnel and the frequent failure messages computed from them.

Every table is a DataFrame (one row per point, robot or message) that ``build_report`` writes as
CSV or turns into the report's tables and plots; nothing here formats for people.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, cast

import pandas as pd

from harness.errors import HarnessError
from harness.failures import FAILURE_REASONS
from harness.report.frames import column, frame_of
from harness.report.stats import wilson_interval
from harness.row import KEY_COLUMNS, param_columns
from harness.runs.store import JSONL_NAME, ResultStore

POINT_KEY: tuple[str, ...] = (*KEY_COLUMNS, "point")


FAIL_PREFIX = "fail."


MAX_MESSAGES = 10


MESSAGE_CHARS = 200


# --------------------------------------------------------------------------------------------
# Loading


def load_episodes(run_dir: str | Path) -> pd.DataFrame:
    """The run's episodes; ``HarnessError`` naming the path if the run or its rows are missing."""
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise HarnessError(f"{run_dir}: run directory not found")
    store = ResultStore(run_dir)
    if not store.exists():
        raise HarnessError(f"{run_dir}: no episodes (expected {JSONL_NAME} or episodes.csv)")
    frame = store.load()
    if frame.empty:
        raise HarnessError(f"{run_dir}: no episodes recorded yet")
    frame.attrs["skipped_lines"] = list(store.skipped_lines)
    return frame


# --------------------------------------------------------------------------------------------
# Aggregation


def _rate_columns(successes: pd.Series, n: pd.Series) -> pd.DataFrame:
    bounds = [wilson_interval(int(k), int(m)) for k, m in zip(successes, n, strict=True)]
    return pd.DataFrame(
        {
            "rate": [int(k) / int(m) if m else math.nan for k, m in zip(successes, n, strict=True)],
            "wilson_lo": [lo for lo, _ in bounds],
            "wilson_hi": [hi for _, hi in bounds],
        },
        index=successes.index,
    )


def failure_reasons_in(frame: pd.DataFrame) -> list[str]:
    """The taxonomy, plus any other reason found in failed rows (``unknown`` for blanks)."""
    failed = frame.loc[~frame["success"], "failure_reason"].replace("", "unknown")
    extra = sorted(set(failed) - set(FAILURE_REASONS))
    return [*FAILURE_REASONS, *extra]


def summarize(frame: pd.DataFrame) -> pd.DataFrame:
    """One row per (task, robot, arm, object, point): counts, rate, Wilson bounds, failures."""
    params = param_columns(frame.columns)
    reasons = failure_reasons_in(frame)
    frame = frame.assign(
        _reason=frame["failure_reason"].where(frame["failure_reason"] != "", "unknown")
    )
    rows: list[dict[str, Any]] = []
    for key, group in frame.groupby(list(POINT_KEY), sort=False, dropna=False):
        row: dict[str, Any] = dict(zip(POINT_KEY, cast(tuple[Any, ...], key), strict=True))
        row["point_id"] = int(column(group, "point_id").min())
        for name in params:
            row[name] = group[name].iloc[0]
        row["n"] = len(group)
        row["successes"] = int(column(group, "success").sum())
        failed = group.loc[~column(group, "success"), "_reason"].value_counts()
        for reason in reasons:
            row[FAIL_PREFIX + reason] = int(failed.get(reason, 0))
        row["median_n_passed_filter"] = float(column(group, "n_passed_filter").median())
        row["median_n_feasible"] = float(column(group, "n_feasible").median())
        row["median_wall_time_s"] = float(column(group, "wall_time_s").median())
        rows.append(row)
    summary = pd.DataFrame(rows)
    if summary.empty:
        return summary
    rates = _rate_columns(column(summary, "successes"), column(summary, "n"))
    fail_columns = [FAIL_PREFIX + reason for reason in reasons]
    medians = ["median_n_passed_filter", "median_n_feasible", "median_wall_time_s"]
    ordered = [
        *KEY_COLUMNS,
        "point_id",
        "point",
        *params,
        "n",
        "successes",
        *rates.columns,
        *fail_columns,
        *medians,
    ]
    summary = frame_of(pd.concat([summary, rates], axis=1)[ordered])
    return summary.sort_values(["robot", "arm", "object", "task", "point_id"], kind="stable")


def pooled(summary: pd.DataFrame, by: list[str]) -> pd.DataFrame:
    """Sum n and successes of summary rows over everything but ``by``; rate and Wilson again."""
    params = param_columns(summary.columns)
    aggregations: dict[str, Any] = {"n": "sum", "successes": "sum"}
    if "point_id" not in by:
        aggregations["point_id"] = "min"
    for name in params:
        if name not in by:
            aggregations[name] = "first"
    fail_columns = [c for c in summary.columns if c.startswith(FAIL_PREFIX)]
    for name in fail_columns:
        aggregations[name] = "sum"
    out = summary.groupby(by, sort=False, dropna=False).agg(aggregations).reset_index()
    return pd.concat([out, _rate_columns(column(out, "successes"), column(out, "n"))], axis=1)


def best_settings(summary: pd.DataFrame) -> pd.DataFrame:
    """Per robot, the point with the highest Wilson lower bound over its arms and objects.

    Ties go to the higher rate, then the larger sample, then the earlier point.
    """
    per_point = pooled(summary, ["robot", "point"])
    per_point["points_compared"] = per_point.groupby("robot")["point"].transform("count")
    ranked = per_point.sort_values(
        ["robot", "wilson_lo", "rate", "n", "point_id"],
        ascending=[True, False, False, False, True],
        kind="stable",
    )
    best = ranked.groupby("robot", sort=True).head(1)
    params = param_columns(summary.columns)
    columns = [
        "robot",
        "point_id",
        "point",
        *params,
        "n",
        "successes",
        "rate",
        "wilson_lo",
        "wilson_hi",
        "points_compared",
    ]
    return frame_of(best[columns]).reset_index(drop=True)


def failure_totals(frame: pd.DataFrame) -> pd.DataFrame:
    """Failure counts per robot (rows) and reason (columns, only reasons that occur)."""
    failed = frame.loc[~frame["success"]]
    if failed.empty:
        return pd.DataFrame(index=pd.Index(sorted(frame["robot"].unique()), name="robot"))
    reasons = failed["failure_reason"].replace("", "unknown")
    table = pd.crosstab(failed["robot"], reasons)
    order = [r for r in failure_reasons_in(frame) if r in table.columns]
    return frame_of(table[order])


def funnel(frame: pd.DataFrame) -> pd.DataFrame:
    """Per robot: candidate sums (total -> passed filter -> feasible -> succeeded) and the
    share of episodes reaching each stage."""
    rows = []
    for robot, group in frame.groupby("robot", sort=True):
        rows.append(
            {
                "robot": robot,
                "episodes": len(group),
                "candidates_total": int(column(group, "n_total").sum()),
                "candidates_passed_filter": int(column(group, "n_passed_filter").sum()),
                "candidates_feasible": int(column(group, "n_feasible").sum()),
                "candidates_succeeded": int(column(group, "success").sum()),
                "median_total": float(column(group, "n_total").median()),
                "median_passed_filter": float(column(group, "n_passed_filter").median()),
                "median_feasible": float(column(group, "n_feasible").median()),
                "episodes_filter_ok": float((column(group, "filter_outcome") == "ok").mean()),
                "episodes_feasible": float((column(group, "n_feasible") > 0).mean()),
                "episodes_success": float(column(group, "success").mean()),
            }
        )
    return pd.DataFrame(rows)


def error_messages(frame: pd.DataFrame) -> pd.DataFrame:
    """The most frequent (reason, message) pairs of failed episodes, with an example id."""
    failed = frame.loc[~frame["success"] & (frame["error_message"] != "")]
    if failed.empty:
        return pd.DataFrame(columns=["failure_reason", "message", "episodes", "example"])
    messages = failed.assign(message=failed["error_message"].str.slice(0, MESSAGE_CHARS))
    table = (
        messages.groupby(["failure_reason", "message"], sort=False)
        .agg(episodes=("episode_id", "size"), example=("episode_id", "first"))
        .reset_index()
        .sort_values(["episodes", "failure_reason"], ascending=[False, True], kind="stable")
    )
    return table.head(MAX_MESSAGES).reset_index(drop=True)
