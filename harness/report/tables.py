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
from harness.report.frames import column, frame_of, series_of
from harness.report.stats import wilson_interval
from harness.row import KEY_COLUMNS, ROBUSTNESS_LEVELS_G, VALIDITY_REASONS, param_columns
from harness.runs.store import JSONL_NAME, ResultStore

POINT_KEY: tuple[str, ...] = (*KEY_COLUMNS, "point")


FAIL_PREFIX = "fail."
GAP_PREFIX = "gap."  # reference successes that are not valid, per invalid_reason
ROBUSTNESS_PREFIX = "robustness."  # episodes per robustness_g level (judged episodes)
OBJECTIVES: tuple[str, ...] = ("reference", "valid")


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


def _valid_rate_columns(valid: pd.Series, judged: pd.Series) -> pd.DataFrame:
    """Valid rate over the episodes the validity phase judged, with its Wilson interval (NaN
    when none was: validity off, or rows written before it existed)."""
    rates = _rate_columns(valid, judged)
    none = judged == 0
    return pd.DataFrame(
        {
            "valid_rate": rates["rate"],
            "valid_ci_low": rates["wilson_lo"].mask(none),
            "valid_ci_high": rates["wilson_hi"].mask(none),
        },
        index=valid.index,
    )


def judged_mask(frame: pd.DataFrame) -> pd.Series:
    """Rows the validity phase judged: valid, or invalid with a reason ('' means off)."""
    if "valid" not in frame or "invalid_reason" not in frame:
        return pd.Series(False, index=frame.index)
    reason = column(frame, "invalid_reason").fillna("").astype(str)
    return series_of(column(frame, "valid").astype(bool) | (reason != ""))


def _validity_counts(group: pd.DataFrame) -> dict[str, Any]:
    """Per point: judged and valid counts, the validity gap per reason, robustness levels."""
    judged = judged_mask(group)
    valid = column(group, "valid").astype(bool) if "valid" in group else judged & False
    n_judged, n_valid = judged.to_numpy().sum(), (valid & judged).to_numpy().sum()
    out: dict[str, Any] = {"n_judged": int(n_judged), "valid": int(n_valid)}
    gap = group.loc[column(group, "success").astype(bool) & judged & ~valid, "invalid_reason"]
    counts = gap.value_counts()
    for reason in VALIDITY_REASONS:
        out[GAP_PREFIX + reason] = int(counts.get(reason, 0))
    robustness = group.loc[judged, "robustness_g"] if "robustness_g" in group else None
    for level in (0.0, *ROBUSTNESS_LEVELS_G):
        hits = 0 if robustness is None else int((robustness == level).sum())
        out[f"{ROBUSTNESS_PREFIX}{level:g}"] = hits
    return out


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
        # ``error`` rows (crashes, input problems) are not picks: never in a rate's denominator.
        errors = int((column(group, "failure_reason") == "error").sum())
        row["n"] = len(group) - errors
        row["n_error"] = errors
        row["successes"] = int(column(group, "success").sum())
        failed = group.loc[~column(group, "success"), "_reason"].value_counts()
        for reason in reasons:
            row[FAIL_PREFIX + reason] = int(failed.get(reason, 0))
        row["median_n_passed_filter"] = float(column(group, "n_passed_filter").median())
        row["median_n_feasible"] = float(column(group, "n_feasible").median())
        row["median_wall_time_s"] = float(column(group, "wall_time_s").median())
        row.update(_validity_counts(group))
        rows.append(row)
    summary = pd.DataFrame(rows)
    if summary.empty:
        return summary
    rates = _rate_columns(column(summary, "successes"), column(summary, "n"))
    valid_rates = _valid_rate_columns(column(summary, "valid"), column(summary, "n_judged"))
    fail_columns = [FAIL_PREFIX + reason for reason in reasons]
    validity = [
        "n_judged", "valid", *valid_rates.columns,
        *[c for c in summary.columns if c.startswith((GAP_PREFIX, ROBUSTNESS_PREFIX))],
    ]  # fmt: skip
    medians = ["median_n_passed_filter", "median_n_feasible", "median_wall_time_s"]
    ordered = [
        *KEY_COLUMNS,
        "point_id",
        "point",
        *params,
        "n",
        "n_error",
        "successes",
        *rates.columns,
        *validity,
        *fail_columns,
        *medians,
    ]
    summary = frame_of(pd.concat([summary, rates, valid_rates], axis=1)[ordered])
    return summary.sort_values(["robot", "arm", "object", "task", "point_id"], kind="stable")


def pooled(summary: pd.DataFrame, by: list[str]) -> pd.DataFrame:
    """Sum n and successes of summary rows over everything but ``by``; rate and Wilson again."""
    params = param_columns(summary.columns)
    aggregations: dict[str, Any] = {"n": "sum", "successes": "sum"}
    if "n_judged" in summary:
        aggregations.update(n_judged="sum", valid="sum")
    if "point_id" not in by:
        aggregations["point_id"] = "min"
    for name in params:
        if name not in by:
            aggregations[name] = "first"
    fail_columns = [
        c for c in summary.columns if c.startswith((FAIL_PREFIX, GAP_PREFIX, ROBUSTNESS_PREFIX))
    ]
    for name in fail_columns:
        aggregations[name] = "sum"
    out = summary.groupby(by, sort=False, dropna=False).agg(aggregations).reset_index()
    parts = [out, _rate_columns(column(out, "successes"), column(out, "n"))]
    if "n_judged" in out:
        parts.append(_valid_rate_columns(column(out, "valid"), column(out, "n_judged")))
    return pd.concat(parts, axis=1)


def best_settings(summary: pd.DataFrame, objective: str = "reference") -> pd.DataFrame:
    """Per robot, the point with the highest Wilson lower bound over its arms and objects, of
    the reference success rate (``objective="reference"``) or of the valid rate (``"valid"``).

    Ties go to the higher rate, then the larger sample, then the earlier point.
    """
    if objective not in OBJECTIVES:
        raise HarnessError(f"objective {objective!r}: expected one of {', '.join(OBJECTIVES)}")
    per_point = pooled(summary, ["robot", "point"])
    per_point["points_compared"] = per_point.groupby("robot")["point"].transform("count")
    if "valid_rate" not in per_point:
        per_point = per_point.assign(
            valid_rate=math.nan, valid_ci_low=math.nan, valid_ci_high=math.nan
        )
    lo, rate = ("valid_ci_low", "valid_rate") if objective == "valid" else ("wilson_lo", "rate")
    ranked = per_point.sort_values(
        ["robot", lo, rate, "n", "point_id"],
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
        "valid_rate",
        "valid_ci_low",
        "valid_ci_high",
        "points_compared",
    ]
    out = frame_of(best[columns]).reset_index(drop=True)
    out.attrs["objective"] = objective
    return out


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
