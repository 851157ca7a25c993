"""The report's sections for people, shared by Markdown and HTML: the overview (what was run,
with which versions) and the rate tables (success per robot, arm and object, best settings,
success per point, the validity gap, failures, the candidate funnel), every cell already
formatted as text, the reference and valid rates side by side with 95% Wilson intervals.
Tables of single episodes (errors, failure groups, examples) are in ``episode_sections``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from harness.report.frames import column, series_rows, tuple_rows
from harness.report.labels import point_label, varying_params
from harness.report.tables import (
    FAIL_PREFIX,
    GAP_PREFIX,
    ROBUSTNESS_PREFIX,
    error_mask,
    failure_totals,
    pooled,
    setting_params,
)
from harness.row import param_columns


def _percent(value: float) -> str:
    return (
        "" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.0%}"
    )


def _ci(lo: float, hi: float) -> str:
    if lo is None or hi is None or math.isnan(lo) or math.isnan(hi):
        return ""
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


FALLBACK_MARK = "⚑"


def fallback_cell(row: Any) -> str:
    """``⚑ 3/20`` when the reference fallback supplied the candidates of some episodes."""
    count = int(row.get("fallback", 0) or 0)
    return f"{FALLBACK_MARK} {count}/{int(row['n'])}" if count else ""


REFERENCE_HEADER, VALID_HEADER = ["reference", "rate", "95% CI"], ["valid", "valid rate", "95% CI"]
RATE_HEADER = [*REFERENCE_HEADER, *VALID_HEADER]


def rate_header(objective: str = "reference") -> list[str]:
    """The rate columns' header, the objective's three first."""
    if objective == "valid":
        return [*VALID_HEADER, *REFERENCE_HEADER]
    return list(RATE_HEADER)


def rate_cells(row: Any, objective: str = "reference") -> list[str]:
    """Reference and valid rate side by side: ``k/n``, rate, Wilson interval, for each; the
    objective's first."""
    judged = int(row.get("n_judged", 0) or 0)
    reference = [
        f"{int(row['successes'])}/{int(row['n'])}",
        _percent(row["rate"]) if row["n"] else "",
        _ci(row["wilson_lo"], row["wilson_hi"]) if row["n"] else "",
    ]
    valid = [
        f"{int(row['valid'])}/{judged}" if judged else "",
        _percent(row["valid_rate"]) if judged else "",
        _ci(row["valid_ci_low"], row["valid_ci_high"]) if judged else "",
    ]
    return [*valid, *reference] if objective == "valid" else [*reference, *valid]


@dataclass(frozen=True)
class Table:
    """One table for people: text cells; ``links`` gives a cell as pieces ``(text, href)``
    (an episode id and its recording, relative to the run directory; ``None``: no link);
    ``flagged`` rows are highlighted (the reference fallback ran)."""

    title: str
    header: list[str]
    rows: list[list[str]]
    note: str = ""
    links: dict[tuple[int, int], list[tuple[str, str | None]]] = field(default_factory=dict)
    flagged: frozenset[int] = frozenset()


def _flagged(frame: pd.DataFrame) -> frozenset[int]:
    if "fallback" not in frame:
        return frozenset()
    return frozenset(i for i, v in enumerate(column(frame, "fallback").tolist()) if v)


RATES_NOTE = (
    "Reference: InternDataEngine's verdict; valid: the grasp really holds (validity phase: no "
    "table penetration, two fingers, 1 s hold, tug at 0.5 g in six directions), over the "
    "episodes it judged. 95% Wilson intervals. error rows are left out of every rate. "
    f"{FALLBACK_MARK}: the filter kept no candidate and the reference fallback supplied them."
)


def report_tables(frame: pd.DataFrame, summary: pd.DataFrame, best: pd.DataFrame) -> list[Table]:
    """The rate tables: per robot, arm and object; best settings; per point; validity gap;
    failure reasons (the candidate funnel is ``funnel_table``). Rate columns put the best
    table's objective (``best.attrs["objective"]``) first."""
    params = setting_params(summary) or varying_params(summary)
    objective = str(best.attrs.get("objective", "reference"))
    tables: list[Table] = [
        _overall_table(summary, objective),
        # best carries the swept settings only; an axis that only picks the object
        # (object.mesh) is in params (it varies) but is no setting, so it is not in best
        _best_table(best, [name for name in params if name in best.columns]),
        _points_table(summary, params, objective),
    ]
    if "n_judged" in summary and column(summary, "n_judged").to_numpy().sum() > 0:
        tables += [_gap_table(summary, params), _robustness_table(summary)]
    totals = failure_totals(frame)
    if totals.shape[1]:
        tables.append(_failures_table(totals))
    return tables


def _overall_table(summary: pd.DataFrame, objective: str) -> Table:
    overall = pooled(summary, ["robot", "arm", "object"]).sort_values(["robot", "arm", "object"])
    return Table(
        "Success per robot, arm and object (all points pooled)",
        ["robot", "arm", "object", *rate_header(objective), "fallback", "errors"],
        [
            [
                str(r["robot"]),
                str(r["arm"]),
                str(r["object"]),
                *rate_cells(r, objective),
                fallback_cell(r),
                str(int(r.get("errors", 0))),
            ]
            for r in series_rows(overall)
        ],
        RATES_NOTE,
        flagged=_flagged(overall),
    )


def _best_table(best: pd.DataFrame, params: list[str]) -> Table:
    objective = best.attrs.get("objective", "reference")
    return Table(
        "Best settings per robot, arm and object",
        [
            *["robot", "arm", "object", "setting", *rate_header(objective)],
            *["fallback", "points compared"],
        ],
        [
            [
                str(r["robot"]),
                str(r["arm"]),
                str(r["object"]),
                point_label(r, params),
                *rate_cells(r, objective),
                fallback_cell(r),
                str(int(r["points_compared"])),
            ]
            for r in series_rows(best)
        ],
        f"Ranked by the lower bound of the 95% Wilson interval of the {objective} rate "
        "(--objective), over the swept settings only: arms and objects are never pooled.",
        flagged=_flagged(best),
    )


def _points_table(summary: pd.DataFrame, params: list[str], objective: str) -> Table:
    return Table(
        "Success per point: reference rate and valid rate",
        [
            *["robot", "arm", "object", "setting", *rate_header(objective)],
            *["fallback", "errors", "top failures"],
        ],
        [
            [
                str(r["robot"]),
                str(r["arm"]),
                str(r["object"]),
                point_label(r, params),
                *rate_cells(r, objective),
                fallback_cell(r),
                str(int(r.get("errors", 0))),
                _top_failures(r),
            ]
            for r in series_rows(summary)
        ],
        RATES_NOTE,
        flagged=_flagged(summary),
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


def funnel_tables(stages: pd.DataFrame) -> list[Table]:
    """The candidate funnel (candidates summed over episodes) and, apart, the episodes that
    reached each stage: candidates and episodes are never mixed in one column."""
    candidates = Table(
        "Candidate funnel (candidates, summed over episodes)",
        ["robot", "candidates", "passed filter", "tested", "feasible"],
        [
            [
                str(r.robot),
                f"{r.candidates_total:,}",
                f"{r.candidates_passed_filter:,}",
                f"{r.candidates_tested:,}",
                f"{r.candidates_feasible:,}",
            ]
            for r in tuple_rows(stages)
        ],
        "Grasp poses in the files, those the direction filters kept, those the feasibility "
        "walk tested (IK / forward test), those found feasible. error rows left out.",
    )
    episodes = Table(
        "Episodes reaching each stage",
        ["robot", "episodes", "filter kept candidates", "feasible candidate", "success"],
        [
            [
                str(r.robot),
                str(r.episodes),
                _share(r.episodes_filter_ok, r.episodes),
                _share(r.episodes_feasible, r.episodes),
                _share(r.episodes_success, r.episodes),
            ]
            for r in tuple_rows(stages)
        ],
        "Episodes whose filter kept at least one candidate, that found a feasible candidate, "
        "that succeeded (reference verdict).",
    )
    return [candidates, episodes]


def _share(share: float, episodes: int) -> str:
    return f"{round(share * episodes)}/{episodes} ({_percent(share)})"


def overview(run_dir: Path, frame: pd.DataFrame) -> list[tuple[str, str]]:
    """The report's head as (key, value) pairs: run, episodes, robots, versions, time."""
    runs = sorted(set(frame["run"]) - {""})
    items = [
        ("run", ", ".join(runs) or run_dir.name),
        ("directory", str(run_dir)),
        ("episodes", _episode_counts(frame)),
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


def _episode_counts(frame: pd.DataFrame) -> str:
    errors = int(error_mask(frame).sum())
    text = f"{len(frame)} ({int(column(frame, 'success').sum())} successes"
    return text + (f", {errors} error rows left out of every rate)" if errors else ")")
