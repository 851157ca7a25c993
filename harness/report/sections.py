"""The report's sections for people, shared by Markdown and HTML: the overview (what was run,
with which versions) and the tables (success per task and point, best settings, failures,
failure messages, the candidate funnel), every cell already formatted as text.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from harness.report.frames import column, series_rows, tuple_rows
from harness.report.labels import point_label, varying_params
from harness.report.tables import (
    FAIL_PREFIX,
    GAP_PREFIX,
    MAX_MESSAGES,
    MESSAGE_CHARS,
    ROBUSTNESS_PREFIX,
    error_messages,
    failure_totals,
    funnel,
    pooled,
)
from harness.row import param_columns


def _percent(value: float) -> str:
    return (
        "" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.0%}"
    )


def _ci(lo: float, hi: float) -> str:
    return f"{lo:.2f}–{hi:.2f}"


def _top_failures(row: Any, limit: int = 2) -> str:
    """The ``limit`` most frequent failures of one summary row (a Series), as ``reason count``."""
    counts = {
        c.removeprefix(FAIL_PREFIX): int(row[c])
        for c in row.index
        if c.startswith(FAIL_PREFIX) and row[c] > 0
    }
    ranked = sorted(counts.items(), key=lambda item: (-item[1], item[0]))[:limit]
    return ", ".join(f"{reason} {count}" for reason, count in ranked)


@dataclass(frozen=True)
class Table:
    title: str
    header: list[str]
    rows: list[list[str]]
    note: str = ""


def report_tables(frame: pd.DataFrame, summary: pd.DataFrame, best: pd.DataFrame) -> list[Table]:
    params = varying_params(summary) or param_columns(summary.columns)
    tables: list[Table] = [
        _overall_table(summary),
        _best_table(best, params),
        _points_table(summary, params),
    ]
    if "n_judged" in summary and column(summary, "n_judged").to_numpy().sum() > 0:
        tables += [_gap_table(summary, params), _robustness_table(summary)]
    totals = failure_totals(frame)
    if totals.shape[1]:
        tables.append(_failures_table(totals))
    messages = error_messages(frame)
    if len(messages):
        tables.append(_messages_table(messages))
    tables.append(_funnel_table(funnel(frame)))
    return tables


def _overall_table(summary: pd.DataFrame) -> Table:
    overall = pooled(summary, ["robot", "arm", "object"])
    return Table(
        "Success per robot, arm and object (all points pooled)",
        ["robot", "arm", "object", "n", "successes", "rate", "95% CI"],
        [
            [
                str(r.robot),
                str(r.arm),
                str(r.object),
                str(int(r.n)),
                str(int(r.successes)),
                _percent(r.rate),
                _ci(r.wilson_lo, r.wilson_hi),
            ]
            for r in tuple_rows(overall.sort_values(["robot", "arm", "object"]))
        ],
    )


def _best_table(best: pd.DataFrame, params: list[str]) -> Table:
    objective = best.attrs.get("objective", "reference")
    return Table(
        "Best settings per robot",
        [
            "robot",
            "setting",
            "n",
            "successes",
            "rate",
            "95% CI",
            "valid rate",
            "valid CI",
            "points compared",
        ],
        [
            [
                str(r["robot"]),
                point_label(r, params),
                str(int(r["n"])),
                str(int(r["successes"])),
                _percent(r["rate"]),
                _ci(r["wilson_lo"], r["wilson_hi"]),
                _percent(r["valid_rate"]),
                "" if math.isnan(r["valid_ci_low"]) else _ci(r["valid_ci_low"], r["valid_ci_high"]),
                str(int(r["points_compared"])),
            ]
            for r in series_rows(best)
        ],
        f"Ranked by the lower bound of the 95% Wilson interval of the {objective} rate "
        "(--objective), pooled over the robot's arms and objects.",
    )


def _points_table(summary: pd.DataFrame, params: list[str]) -> Table:
    judged = "n_judged" in summary
    return Table(
        "Success per point: reference rate and valid rate",
        [
            "robot",
            "arm",
            "object",
            "setting",
            "n",
            "reference rate",
            "95% CI",
            "valid",
            "valid rate",
            "95% CI",
            "top failures",
        ],
        [
            [
                str(r["robot"]),
                str(r["arm"]),
                str(r["object"]),
                point_label(r, params),
                f"{int(r['successes'])}/{int(r['n'])}",
                _percent(r["rate"]),
                _ci(r["wilson_lo"], r["wilson_hi"]),
                f"{int(r['valid'])}/{int(r['n_judged'])}" if judged and r["n_judged"] else "",
                _percent(r["valid_rate"]) if judged else "",
                _ci(r["valid_ci_low"], r["valid_ci_high"]) if judged and r["n_judged"] else "",
                _top_failures(r),
            ]
            for r in series_rows(summary)
        ],
        "Valid: the grasp really holds (validity phase: no table penetration, two fingers, "
        "1 s hold, tug at 0.5 g in six directions), over the episodes it judged.",
    )


def _gap_table(summary: pd.DataFrame, params: list[str]) -> Table:
    reasons = [
        str(c)
        for c in summary.columns
        if str(c).startswith(GAP_PREFIX) and column(summary, c).to_numpy().sum() > 0
    ]
    return Table(
        "Validity gap: reference successes that are not valid, by reason",
        [
            "robot",
            "arm",
            "object",
            "setting",
            "reference successes",
            "not valid",
            *[c.removeprefix(GAP_PREFIX) for c in reasons],
        ],
        [
            [
                str(r["robot"]),
                str(r["arm"]),
                str(r["object"]),
                point_label(r, params),
                str(int(r["successes"])),
                str(int(sum(r[c] for c in reasons))),
                *[str(int(r[c])) for c in reasons],
            ]
            for r in series_rows(summary)
        ],
    )


def _robustness_table(summary: pd.DataFrame) -> Table:
    overall = pooled(summary, ["robot", "arm", "object"])
    levels = [c for c in summary.columns if c.startswith(ROBUSTNESS_PREFIX)]
    return Table(
        "Distribution of robustness_g (judged episodes, all points pooled)",
        ["robot", "arm", "object", *[f"{c.removeprefix(ROBUSTNESS_PREFIX)} g" for c in levels]],
        [
            [str(r["robot"]), str(r["arm"]), str(r["object"]), *[str(int(r[c])) for c in levels]]
            for r in series_rows(overall.sort_values(["robot", "arm", "object"]))
        ],
        "robustness_g: the largest tug (x g x mass) the grasp survived in all six directions; "
        "0: it failed at 0.5 g or the object was not held.",
    )


def _failures_table(totals: pd.DataFrame) -> Table:
    return Table(
        "Failure reasons per robot",
        ["robot", *map(str, totals.columns), "total"],
        [
            [str(robot), *[str(int(v)) for v in values], str(int(sum(values)))]
            for robot, values in zip(totals.index, totals.to_numpy(), strict=True)
        ],
    )


def _messages_table(messages: pd.DataFrame) -> Table:
    return Table(
        "Failure messages",
        ["reason", "message", "episodes", "example episode"],
        [
            [str(r.failure_reason), str(r.message), str(r.episodes), str(r.example)]
            for r in tuple_rows(messages)
        ],
        f"The {MAX_MESSAGES} most frequent messages of failed episodes "
        f"(cut at {MESSAGE_CHARS} characters).",
    )


def _funnel_table(stages: pd.DataFrame) -> Table:
    return Table(
        "Candidate funnel",
        [
            "robot",
            "episodes",
            "candidates",
            "passed filter",
            "feasible",
            "succeeded",
            "episodes filter ok",
            "episodes feasible",
            "episodes success",
        ],
        [
            [
                str(r.robot),
                str(r.episodes),
                f"{r.candidates_total:,}",
                f"{r.candidates_passed_filter:,}",
                f"{r.candidates_feasible:,}",
                f"{r.candidates_succeeded:,}",
                _percent(r.episodes_filter_ok),
                _percent(r.episodes_feasible),
                _percent(r.episodes_success),
            ]
            for r in tuple_rows(stages)
        ],
        "Candidate sums over all episodes; the last three columns are shares of episodes "
        "whose filter kept candidates, that found a feasible candidate, that succeeded.",
    )


def overview(run_dir: Path, frame: pd.DataFrame) -> list[tuple[str, str]]:
    """The report's head as (key, value) pairs: run, episodes, robots, versions, time."""
    runs = sorted(set(frame["run"]) - {""})
    items = [
        ("run", ", ".join(runs) or run_dir.name),
        ("directory", str(run_dir)),
        ("episodes", f"{len(frame)} ({int(column(frame, 'success').sum())} successes)"),
        ("robots", ", ".join(sorted(set(frame["robot"])))),
        ("objects", ", ".join(sorted(set(frame["object"])))),
        ("semantics", ", ".join(sorted(set(frame["semantics"]) - {""})) or "?"),
        ("swept parameters", ", ".join(param_columns(frame.columns)) or "none"),
        ("versions", _versions(frame)),
        ("generated", time.strftime("%Y-%m-%d %H:%M:%S")),
    ]
    skipped = frame.attrs.get("skipped_lines") or []
    if skipped:
        items.append(("unreadable lines skipped", f"{len(skipped)} (lines {skipped[:10]})"))
    return items


def _versions(frame: pd.DataFrame) -> str:
    harness = sorted(set(frame["harness_version"]) - {""})
    mujoco = sorted(set(frame["mujoco_version"]) - {""})
    return f"pick-harness {', '.join(harness) or '?'}; MuJoCo {', '.join(mujoco) or '?'}"
