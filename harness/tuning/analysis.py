"""The tune's statistics: success maps, the best setting, and its paired test against the current.

A *setting* is the pair (approach filter, facing filter) of a grid point, as the JSON of its
``param.pick.approach_filter`` / ``param.pick.facing_filter`` columns. Per robot, arm and object
(and per robot and arm, pooled over objects) the success map holds n, successes, rate and the 95%
Wilson interval of every setting; the best setting has the highest lower bound (ties: higher
rate, larger n, earlier grid point), and is tested against the task's current setting with the
exact McNemar test on the pairs of episodes that share a seed (common random numbers: episode k
of every point sees the same scene).
"""

from __future__ import annotations

import json
from typing import Any

import pandas as pd

from harness.errors import HarnessError
from harness.report.frames import column, frame_of, series_rows
from harness.report.stats import mcnemar_exact, wilson_interval
from harness.row import param_columns
from harness.tuning.grid import APPROACH_KEY, FACING_KEY

APPROACH_COLUMN = "param." + APPROACH_KEY
FACING_COLUMN = "param." + FACING_KEY
SETTING = ["approach", "facing"]
POOLED = "*"  # the object value of a robot/arm's row pooled over its objects


def filter_label(text: str) -> str:
    """``'["downward", 140.0]'`` -> ``downward 140``; a band -> ``downward 90-120``."""
    value = json.loads(text) if text else None
    if not value:
        return "none"
    direction, *angles = value
    return f"{direction} {'-'.join(f'{a:g}' for a in angles)}"


def settings_frame(frame: pd.DataFrame, objective: str) -> pd.DataFrame:
    """One row per episode: robot, arm, object, task, context, seed, approach, facing, ok.

    ``ok`` is the reference success or, with ``objective="valid"``, the validity verdict.
    ``context`` joins the point's other swept values (episodes pair within a context).
    """
    missing = [c for c in (APPROACH_COLUMN, FACING_COLUMN) if c not in frame.columns]
    if missing:
        raise HarnessError(f"not a tune run: the episodes have no {missing[0]} column")
    others = [c for c in param_columns(frame.columns) if c not in (APPROACH_COLUMN, FACING_COLUMN)]
    context = frame[others].astype(str).agg(" | ".join, axis=1) if others else ""
    verdict = "valid" if objective == "valid" else "success"
    return pd.DataFrame(
        {
            "robot": frame["robot"],
            "arm": frame["arm"],
            "object": frame["object"],
            "task": frame["task"],
            "context": context,
            "seed": frame["seed"],
            "point_id": frame["point_id"],
            "approach": column(frame, APPROACH_COLUMN).astype(str),
            "facing": column(frame, FACING_COLUMN).astype(str),
            "ok": column(frame, verdict).astype(bool),
        }
    )


def success_map(settings: pd.DataFrame, by: list[str]) -> pd.DataFrame:
    """Per ``by`` group and setting: n, successes, rate, Wilson bounds (lo, hi), point order."""
    grouped = settings.groupby([*by, *SETTING], sort=False)
    table = grouped.agg(
        n=("ok", "size"), successes=("ok", "sum"), order=("point_id", "min")
    ).reset_index()
    bounds = [
        wilson_interval(int(k), int(n)) for k, n in zip(table["successes"], table["n"], strict=True)
    ]
    table["rate"] = table["successes"] / table["n"]
    table["lo"] = [b[0] for b in bounds]
    table["hi"] = [b[1] for b in bounds]
    return table


def best_of(table: pd.DataFrame, by: list[str]) -> pd.DataFrame:
    """Per ``by`` group, the setting with the highest lower bound (ties: rate, n, grid order)."""
    ranked = table.sort_values(
        [*by, "lo", "rate", "n", "order"],
        ascending=[*([True] * len(by)), False, False, False, True],
        kind="stable",
    )
    return frame_of(ranked.groupby(by, sort=True).head(1)).reset_index(drop=True)


def paired_counts(
    settings: pd.DataFrame, best: tuple[str, str], current: tuple[str, str]
) -> tuple[int, int, int]:
    """(pairs, current-only successes, best-only successes) over episodes sharing a seed."""
    keys = ["task", "context", "seed"]

    def outcomes(setting: tuple[str, str]) -> pd.DataFrame:
        chosen = (settings["approach"] == setting[0]) & (settings["facing"] == setting[1])
        return frame_of(settings.loc[chosen, [*keys, "ok"]])

    pairs = outcomes(current).merge(outcomes(best), on=keys, suffixes=("_current", "_best"))
    a, b = column(pairs, "ok_current"), column(pairs, "ok_best")
    return len(pairs), int((a & ~b).sum()), int((b & ~a).sum())


def choices(
    settings: pd.DataFrame, current: dict[tuple[str, str], tuple[str, str]]
) -> pd.DataFrame:
    """Per robot, arm and object, and per robot and arm pooled (object ``*``): the best setting,
    the current setting's stats, and the exact McNemar test of best vs current.

    ``current`` maps (robot, arm) to the current (approach, facing) JSON pair.
    """
    per_object = success_map(settings, ["robot", "arm", "object"])
    pooled = success_map(settings, ["robot", "arm"]).assign(object=POOLED)
    rows: list[dict[str, Any]] = []
    for table in (per_object, pooled):
        by = ["robot", "arm", "object"]
        points = table.groupby(by, sort=False)["n"].transform("size")
        table = table.assign(points=points)
        for best in series_rows(best_of(table, by)):
            rows.append(_choice_row(settings, table, best, current))
    out = pd.DataFrame(rows)
    return out.sort_values(["robot", "arm", "object"], kind="stable").reset_index(drop=True)


def _choice_row(
    settings: pd.DataFrame,
    table: pd.DataFrame,
    best: Any,
    current: dict[tuple[str, str], tuple[str, str]],
) -> dict[str, Any]:
    robot, arm, obj = str(best["robot"]), str(best["arm"]), str(best["object"])
    now = current.get((robot, arm))
    if now is None:
        raise HarnessError(f"no current setting known for {robot} {arm}")
    mine = (table["robot"] == robot) & (table["arm"] == arm) & (table["object"] == obj)
    at_now = frame_of(table[mine & (table["approach"] == now[0]) & (table["facing"] == now[1])])
    if at_now.empty:
        raise HarnessError(f"the current setting of {robot} {arm} is not a grid point")
    cur = at_now.iloc[0]
    scope = settings if obj == POOLED else frame_of(settings[settings["object"] == obj])
    scope = frame_of(scope[(scope["robot"] == robot) & (scope["arm"] == arm)])
    pairs, only_current, only_best = paired_counts(
        scope, (str(best["approach"]), str(best["facing"])), now
    )
    test = mcnemar_exact(only_current, only_best)
    return {
        "robot": robot,
        "arm": arm,
        "object": obj,
        "points": int(best["points"]),
        "approach": best["approach"],
        "facing": best["facing"],
        **{k: best[k] for k in ("n", "successes", "rate", "lo", "hi")},
        "current_approach": now[0],
        "current_facing": now[1],
        **{f"current_{k}": cur[k] for k in ("n", "successes", "rate", "lo", "hi")},
        "pairs": pairs,
        "only_best": only_best,
        "only_current": only_current,
        "p_value": test.p_value,
    }
