"""The run's data tables: its episodes, and per-point summaries, best settings, failure counts,
the candidate funnel and the frequent failure messages computed from them.

Every table is a DataFrame (one row per point, robot or message) that ``build_report`` writes as
CSV or turns into the report's tables and plots; nothing here formats for people.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from harness.errors import HarnessError
from harness.failures import FAILURE_REASONS, UNRATED_REASONS
from harness.report.frames import column, frame_of, series_of
from harness.report.objective import OBJECTIVES, effective_objective
from harness.report.stats import wilson_interval
from harness.row import KEY_COLUMNS, ROBUSTNESS_LEVELS_G, VALIDITY_REASONS, param_columns
from harness.runs.store import JSONL_NAME, ResultStore

POINT_KEY: tuple[str, ...] = (*KEY_COLUMNS, "point")


FAIL_PREFIX = "fail."
GAP_PREFIX = "gap."  # reference successes that are not valid, per invalid_reason
ROBUSTNESS_PREFIX = "robustness."  # episodes per robustness_g level (judged episodes)


MAX_MESSAGES = 10


MESSAGE_CHARS = 200


ERROR_REASON = "error"  # a crashed worker or bad input: not a pick outcome, never in a rate
FALLBACK_OUTCOME = "fallback"  # filter_outcome: the filter kept nothing, the reference fell back


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


def error_mask(frame: pd.DataFrame) -> pd.Series:
    """Rows whose episode did not run to a verdict (``failure_reason == "error"``)."""
    return series_of(column(frame, "failure_reason").fillna("").astype(str) == ERROR_REASON)


def rated(frame: pd.DataFrame) -> pd.DataFrame:
    """The episodes that count in rates: every row but the ``error`` and ``not_runnable`` rows
    (``harness.failures.UNRATED_REASONS``)."""
    reasons = column(frame, "failure_reason").fillna("").astype(str)
    return frame_of(frame.loc[~reasons.isin(UNRATED_REASONS)])


def fallback_mask(frame: pd.DataFrame) -> pd.Series:
    """Rows whose candidates came from the reference fallback (the filter kept nothing)."""
    if "filter_outcome" not in frame:
        return pd.Series(False, index=frame.index)
    return series_of(column(frame, "filter_outcome").fillna("").astype(str) == FALLBACK_OUTCOME)


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


def _validity_counts(arrays: _PointArrays, rows: np.ndarray) -> dict[str, Any]:
    """Per point (its rated ``rows``): judged and valid counts, the validity gap per reason,
    robustness levels."""
    judged, valid = arrays.judged[rows], arrays.valid[rows]
    out: dict[str, Any] = {"n_judged": int(judged.sum()), "valid": int((valid & judged).sum())}
    gap = Counter(arrays.invalid_reason[rows][arrays.success[rows] & judged & ~valid].tolist())
    for reason in VALIDITY_REASONS:
        out[GAP_PREFIX + reason] = gap.get(reason, 0)
    robustness = arrays.robustness[rows][judged] if arrays.robustness is not None else None
    for level in (0.0, *ROBUSTNESS_LEVELS_G):
        hits = 0 if robustness is None else int((robustness == level).sum())
        out[f"{ROBUSTNESS_PREFIX}{level:g}"] = hits
    return out


@dataclass(frozen=True)
class _PointArrays:
    """The columns ``summarize`` counts per point, as arrays: a dense grid has a point per few
    rows, and pandas selections per point cost ~2.5 ms each (a 342-point report spent ~1 s)."""

    point_id: np.ndarray
    unrated: np.ndarray
    error: np.ndarray
    fallback: np.ndarray
    success: np.ndarray
    reason: np.ndarray  # failure_reason, '' as "unknown"
    judged: np.ndarray
    valid: np.ndarray
    invalid_reason: np.ndarray
    robustness: np.ndarray | None
    medians: dict[str, np.ndarray]

    @staticmethod
    def of(frame: pd.DataFrame) -> _PointArrays:
        has_validity = "valid" in frame and "invalid_reason" in frame
        judged = judged_mask(frame).to_numpy(dtype=bool)
        valid = column(frame, "valid").astype(bool) if "valid" in frame else None
        reason = column(frame, "failure_reason")
        return _PointArrays(
            point_id=column(frame, "point_id").to_numpy(),
            unrated=reason.fillna("").astype(str).isin(UNRATED_REASONS).to_numpy(dtype=bool),
            error=error_mask(frame).to_numpy(dtype=bool),
            fallback=fallback_mask(frame).to_numpy(dtype=bool),
            success=column(frame, "success").to_numpy(dtype=bool),
            reason=reason.where(reason != "", "unknown").to_numpy(dtype=object),
            judged=judged,
            valid=valid.to_numpy(dtype=bool) if valid is not None else judged & False,
            invalid_reason=(
                column(frame, "invalid_reason").to_numpy(dtype=object)
                if has_validity
                else np.full(len(frame), "", dtype=object)
            ),
            robustness=(
                column(frame, "robustness_g").to_numpy(dtype=float)
                if "robustness_g" in frame
                else None
            ),
            medians={
                name: column(frame, name).to_numpy(dtype=float)
                for name in ("n_passed_filter", "n_feasible", "wall_time_s")
            },
        )


def _median(values: np.ndarray) -> float:
    """The median of the non-NaN values (pandas' ``Series.median``), NaN when there are none."""
    present = values[~np.isnan(values)]
    return float(np.median(present)) if len(present) else math.nan


def failure_reasons_in(frame: pd.DataFrame) -> list[str]:
    """The taxonomy, plus any other reason found in failed rows (``unknown`` for blanks)."""
    failed = frame.loc[~frame["success"], "failure_reason"].replace("", "unknown")
    extra = sorted(set(failed) - set(FAILURE_REASONS))
    return [*FAILURE_REASONS, *extra]


def summarize(frame: pd.DataFrame) -> pd.DataFrame:
    """One row per (task, robot, arm, object, point): counts, rate, Wilson bounds, failures.

    ``error`` rows (a crashed worker, bad input) are not pick outcomes: they are left out of
    ``n``, the rates and the failure counts and counted in ``errors``. ``not_runnable`` rows (a
    pick that depends on earlier skills) are left out the same way, not counted as errors.
    ``fallback`` counts the
    rated episodes whose candidates came from the reference fallback (the filter kept nothing).
    """
    params = param_columns(frame.columns)
    reasons = failure_reasons_in(frame)
    arrays = _PointArrays.of(frame)
    codes = frame.groupby(list(POINT_KEY), sort=False, dropna=False).ngroup().to_numpy()
    order = np.argsort(codes, kind="stable")  # each point's rows, in file order
    starts = np.flatnonzero(np.r_[True, np.diff(codes[order]) != 0])
    rows: list[dict[str, Any]] = []
    for everything in np.split(order, starts[1:]) if len(order) else []:
        first = int(everything[0])
        row: dict[str, Any] = {name: frame[name].iloc[first] for name in POINT_KEY}
        row["point_id"] = int(arrays.point_id[everything].min())
        for name in params:
            row[name] = frame[name].iloc[first]
        group = everything[~arrays.unrated[everything]]
        row["errors"] = int(arrays.error[everything].sum())  # never in a rate
        row["fallback"] = int(arrays.fallback[group].sum())
        row["n"] = len(group)
        row["successes"] = int(arrays.success[group].sum())
        failed = Counter(arrays.reason[group][~arrays.success[group]].tolist())
        for reason in reasons:
            row[FAIL_PREFIX + reason] = failed.get(reason, 0)
        for name, values in arrays.medians.items():
            row[f"median_{name}"] = _median(values[group]) if len(group) else math.nan
        row.update(_validity_counts(arrays, group))
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
        "successes",
        *rates.columns,
        *validity,
        "fallback",
        "errors",
        *fail_columns,
        *medians,
    ]
    summary = frame_of(pd.concat([summary, rates, valid_rates], axis=1)[ordered])
    return summary.sort_values(["robot", "arm", "object", "task", "point_id"], kind="stable")


def pooled(summary: pd.DataFrame, by: list[str]) -> pd.DataFrame:
    """Sum n and successes of summary rows over everything but ``by``; rate and Wilson again."""
    params = param_columns(summary.columns)
    aggregations: dict[str, Any] = {"n": "sum", "successes": "sum"}
    for name in ("fallback", "errors"):
        if name in summary:
            aggregations[name] = "sum"
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


GROUP_KEY: list[str] = ["robot", "arm", "object"]


def setting_params(summary: pd.DataFrame) -> list[str]:
    """The swept settings: ``param.*`` columns that take more than one value for some robot,
    arm and object. An axis that only picks the object (``object.mesh``) is not a setting: it
    never varies once the object is fixed."""
    params = param_columns(summary.columns)
    if summary.empty:
        return []
    varying = summary.groupby(GROUP_KEY, sort=False, dropna=False)[params].nunique(dropna=True)
    return [name for name in params if bool((varying[name] > 1).any())]


def ranked_points(summary: pd.DataFrame, objective: str = "valid") -> pd.DataFrame:
    """Every point pooled per robot, arm and object, each group's points best first: by the
    Wilson lower bound of the objective's rate (``harness.report.objective``), then the rate,
    the larger sample, the earlier point. ``points_compared`` counts each group's points."""
    if objective not in OBJECTIVES:
        raise HarnessError(f"objective {objective!r}: expected one of {', '.join(OBJECTIVES)}")
    per_point = pooled(summary, [*GROUP_KEY, "point"])
    per_point["points_compared"] = per_point.groupby(GROUP_KEY)["point"].transform("count")
    if "valid_rate" not in per_point:
        per_point = per_point.assign(
            valid_rate=math.nan, valid_ci_low=math.nan, valid_ci_high=math.nan
        )
    for name in ("n_judged", "valid", "fallback", "errors"):
        if name not in per_point:
            per_point[name] = 0
    lo, rate = ("valid_ci_low", "valid_rate") if objective == "valid" else ("wilson_lo", "rate")
    return per_point.sort_values(
        [*GROUP_KEY, lo, rate, "n", "point_id"],
        ascending=[True, True, True, False, False, False, True],
        kind="stable",
        na_position="last",
    )


def best_settings(summary: pd.DataFrame, objective: str = "valid") -> pd.DataFrame:
    """Per robot, arm and object, the point with the highest Wilson lower bound of the
    valid rate (``objective="valid"``) or of the reference success rate (``"reference"``),
    ranked over the swept settings only (arms and objects are never pooled, never a setting).

    Ties go to the higher rate, then the larger sample, then the earlier point. ``valid``
    without any judged episode ranks by the reference rate (``attrs["objective"]`` says which).
    """
    objective = effective_objective(summary, objective)
    ranked = ranked_points(summary, objective)
    best = ranked.groupby(GROUP_KEY, sort=True).head(1)
    settings = setting_params(summary)
    columns = [
        *GROUP_KEY,
        "point_id",
        "point",
        *settings,
        "n",
        "successes",
        "rate",
        "wilson_lo",
        "wilson_hi",
        "n_judged",
        "valid",
        "valid_rate",
        "valid_ci_low",
        "valid_ci_high",
        "fallback",
        "errors",
        "points_compared",
    ]
    out = frame_of(best[columns]).reset_index(drop=True)
    out.attrs["objective"] = objective
    out.attrs["settings"] = settings
    return out


def failure_totals(frame: pd.DataFrame) -> pd.DataFrame:
    """Failure counts per robot (rows) and reason (columns, only reasons that occur); ``error``
    rows are not failures of the pick and have their own table (``error_rows``)."""
    frame = rated(frame)
    failed = frame.loc[~frame["success"]]
    if failed.empty:
        return pd.DataFrame(index=pd.Index(sorted(frame["robot"].unique()), name="robot"))
    reasons = failed["failure_reason"].replace("", "unknown")
    table = pd.crosstab(failed["robot"], reasons)
    order = [r for r in failure_reasons_in(frame) if r in table.columns]
    return frame_of(table[order])


FUNNEL_COLUMNS: tuple[str, ...] = (
    "robot", "episodes", "candidates_total", "candidates_passed_filter", "candidates_tested",
    "candidates_feasible", "candidates_succeeded", "median_total", "median_passed_filter",
    "median_feasible",
    "episodes_filter_ok", "episodes_feasible", "episodes_success",
)  # fmt: skip


def funnel(frame: pd.DataFrame) -> pd.DataFrame:
    """Per robot: candidate sums (total -> passed filter -> feasible -> succeeded) and the
    share of episodes reaching each stage (``error`` rows left out)."""
    frame = rated(frame)
    rows = []
    for robot, group in frame.groupby("robot", sort=True):
        rows.append(
            {
                "robot": robot,
                "episodes": len(group),
                "candidates_total": int(column(group, "n_total").sum()),
                "candidates_passed_filter": int(column(group, "n_passed_filter").sum()),
                "candidates_tested": int(column(group, "n_tested").sum())
                if "n_tested" in group
                else 0,
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
    return pd.DataFrame(rows, columns=list(FUNNEL_COLUMNS))


def error_messages(frame: pd.DataFrame) -> pd.DataFrame:
    """The most frequent (reason, message) pairs of failed episodes, with an example id."""
    frame = rated(frame)
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


ERROR_COLUMNS: tuple[str, ...] = (
    "episode_id", "robot", "arm", "object", "point", "seed", "error_message",
)  # fmt: skip


def error_rows(frame: pd.DataFrame) -> pd.DataFrame:
    """The ``error`` rows (left out of every rate), with their messages, in run order."""
    errors = frame_of(frame.loc[error_mask(frame)])
    present = [name for name in ERROR_COLUMNS if name in errors]
    return frame_of(errors[present]).reset_index(drop=True)
