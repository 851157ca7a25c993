"""Comparing two runs: per-point success-rate differences with a two-proportion test.

``compare_runs(run_a, run_b)`` matches points between two runs and tests each rate difference.
"""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd

from harness.report.frames import frame_of, series_rows
from harness.report.stats import compare_proportions
from harness.report.tables import POINT_KEY, load_episodes, summarize
from harness.row import KEY_COLUMNS, param_columns


def compare_runs(run_a: str | Path, run_b: str | Path) -> pd.DataFrame:
    """Per-point rate difference ``rate_b - rate_a`` with its test, matched on the point key.

    The key is (task, robot, arm, object, point JSON). Points found in one run only are listed
    with ``present`` = ``a only`` / ``b only`` and no test. ``test`` is ``z`` (pooled
    two-proportion z-test) or ``fisher`` (exact, when an expected count is below 5).
    """
    summary_a = summarize(load_episodes(run_a))
    summary_b = summarize(load_episodes(run_b))
    params = list(
        dict.fromkeys(param_columns(summary_a.columns) + param_columns(summary_b.columns))
    )
    keep = [*POINT_KEY, "point_id", "n", "successes", "rate"]
    merged = pd.merge(
        summary_a[keep],
        summary_b[keep],
        on=list(POINT_KEY),
        how="outer",
        suffixes=("_a", "_b"),
        indicator=True,
    )
    params_frame = pd.concat(
        [
            frame_of(summary_a[[*POINT_KEY, *_present(summary_a, params)]]),
            frame_of(summary_b[[*POINT_KEY, *_present(summary_b, params)]]),
        ]
    )
    params_frame = params_frame.drop_duplicates(list(POINT_KEY), keep="first")
    merged = merged.merge(params_frame, on=list(POINT_KEY), how="left")
    merged["present"] = (
        merged.pop("_merge")
        .map({"both": "both", "left_only": "a only", "right_only": "b only"})
        .astype("str")
    )
    _add_tests(merged)
    merged["point_id"] = merged["point_id_a"].fillna(merged["point_id_b"]).astype("int64")
    for name in ("n_a", "successes_a", "n_b", "successes_b"):
        merged[name] = merged[name].fillna(0).astype("int64")
    columns = [
        *KEY_COLUMNS,
        "point_id",
        "point",
        *[p for p in params if p in merged.columns],
        "n_a",
        "successes_a",
        "rate_a",
        "n_b",
        "successes_b",
        "rate_b",
        "difference",
        "z",
        "p_value",
        "test",
        "present",
    ]
    merged = merged.sort_values(["robot", "arm", "object", "task", "point_id"], kind="stable")
    return frame_of(merged[columns]).reset_index(drop=True)


def _add_tests(merged: pd.DataFrame) -> None:
    """Columns difference, z, p_value and test of every point present in both runs."""
    tests = []
    for row in series_rows(merged):
        if row["present"] != "both":
            tests.append((math.nan, math.nan, math.nan, ""))
            continue
        result = compare_proportions(
            int(row["successes_a"]), int(row["n_a"]), int(row["successes_b"]), int(row["n_b"])
        )
        tests.append((result.difference, result.z, result.p_value, result.test))
    merged["difference"] = [t[0] for t in tests]
    merged["z"] = [t[1] for t in tests]
    merged["p_value"] = [t[2] for t in tests]
    merged["test"] = pd.Series([t[3] for t in tests], index=merged.index, dtype="str")


def _present(frame: pd.DataFrame, names: list[str]) -> list[str]:
    return [name for name in names if name in frame.columns]
