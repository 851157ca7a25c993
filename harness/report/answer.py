"""The report's first screen: per robot, arm and object, which setting, how sure, why the rest
fail.

For a sweep the answer is the swept setting with the highest Wilson lower bound of the
objective's rate (``ranked_points``), worded as a candidate ("not confirmed on fresh seeds; run
harness tune"): the sweep chose it on the same seeds it is measured on. When every setting
scores zero the answer is "no setting helps" with the dominant cause; with one setting run,
"keep" (nothing was compared). Each answer carries the rate with its 95% Wilson interval, the
other rate beside it, the runner-up, and the one-line reason: the dominant causes of the
episodes that did not meet the objective at that setting.

A tune's decisions (``harness.report.tune_link``) replace the sweep's candidates where they
exist: they were tested on fresh seeds.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import pandas as pd

from harness.report.frames import frame_of, series_rows
from harness.report.labels import point_label
from harness.report.objective import RATES, REFERENCE, other
from harness.report.sections import Table
from harness.report.stats import wilson_interval
from harness.report.tables import FAIL_PREFIX, GAP_PREFIX, GROUP_KEY, ranked_points

UNCONFIRMED = "not confirmed on fresh seeds; run harness tune"
NO_SETTING = "no setting helps"
REASON_LIMIT = 3  # causes named in the one-line reason


@dataclass(frozen=True)
class Answer:
    """One unit's answer, every field text for people."""

    robot: str
    arm: str
    object: str
    decision: str  # "best swept setting", "keep", "no setting helps: <cause>", a tune verdict
    setting: str
    rate: str  # the objective's rate with its interval
    other_rate: str  # the other verdict's rate
    runner_up: str
    reason: str
    note: str = ""  # "not confirmed on fresh seeds ...", seeds used, what it could detect

    @property
    def unit(self) -> str:
        return f"{self.robot} {self.arm} {self.object}"


@dataclass(frozen=True)
class FirstScreen:
    """What the report opens on: the answer tables (a tune's decisions first), the objective,
    the tune this run belongs to, links to tunes of the same tasks, a note on the objective."""

    tables: list[Table]
    objective: str
    tune_path: Path | None = None
    tune_links: list[tuple[str, str]] = field(default_factory=list)
    note: str = ""


HEADER = ["unit", "decision", "setting", "rate (95% CI)", "beside it", "runner-up", "why the rest"]


def causes(row: Any, objective: str) -> Counter[str]:
    """Why the episodes of one summary row did not meet the objective: each failure reason
    and, for ``valid``, each reason a reference success was not valid."""
    counts: Counter[str] = Counter()
    for name in row.index:
        text = str(name)
        value = row[name]
        if not isinstance(value, (int, float)) or isinstance(value, bool) or math.isnan(value):
            continue
        if text.startswith(FAIL_PREFIX) and value > 0:
            counts[text.removeprefix(FAIL_PREFIX)] += int(value)
        elif objective != REFERENCE and text.startswith(GAP_PREFIX) and value > 0:
            counts[text.removeprefix(GAP_PREFIX)] += int(value)
    return counts


def cause_line(counts: Counter[str], total: int, limit: int = REASON_LIMIT) -> str:
    """``12 of 40 fail: no_feasible_candidate 7, table_penetration 5``."""
    missed = sum(counts.values())
    if not missed:
        return "every episode met the objective"
    ranked = sorted(counts.items(), key=lambda item: (-item[1], item[0]))[:limit]
    return f"{missed} of {total} miss: " + ", ".join(f"{r} {c}" for r, c in ranked)


def sweep_answers(summary: pd.DataFrame, objective: str, params: list[str]) -> list[Answer]:
    """One answer per robot, arm and object of a sweep (see the module docstring)."""
    if summary.empty:
        return []
    ranked = ranked_points(summary, objective)
    rate, beside = RATES[objective], RATES[other(objective)]
    answers = []
    for key, group in ranked.groupby(GROUP_KEY, sort=True):
        robot, arm, obj = (str(part) for part in key)  # type: ignore[union-attr]
        rows = list(series_rows(frame_of(group)))
        best = rows[0]
        k, n, *_ = rate.of(best)
        label = point_label(best, params) if params else "the task's setting"
        runner = (
            f"{point_label(rows[1], params)}: {rate.text(rows[1], interval=False)}"
            if len(rows) > 1 and params
            else "none (one setting run)"
        )
        total, shown, other_shown = int(best["n"]), "", ""
        if not total:
            decision, note = "no rated episodes", "every row an error: see the error table"
            reason = f"{int(best.get('errors', 0) or 0)} error rows"
        elif not n:
            decision, note = f"not judged by the {objective} verdict", "validity off here"
            reason = cause_line(causes(best, REFERENCE), total)
        elif k == 0:
            pooled_causes: Counter[str] = Counter()
            for row in rows:
                pooled_causes.update(causes(row, objective))
            top = pooled_causes.most_common(1)[0][0] if pooled_causes else "unknown"
            decision, label = f"{NO_SETTING}: {top}", "any swept setting"
            n_all = sum(rate.of(r)[1] for r in rows)
            lo, hi = wilson_interval(0, n_all) if n_all else (math.nan, math.nan)
            shown = f"{objective} 0/{n_all} over all settings (0%, {lo:.2f}–{hi:.2f})"
            k_other = sum(beside.of(r)[0] for r in rows)
            n_other = sum(beside.of(r)[1] for r in rows)
            other_shown = (
                f"{beside.name} {k_other}/{n_other} ({k_other / n_other:.0%}) over all settings"
                if n_other
                else beside.text(best)
            )
            note = (
                f"0 {objective} successes at all {len(rows)} setting(s) run; the cause is "
                "upstream of the filter (task, object or robot), not a setting to pick"
            )
            reason = cause_line(pooled_causes, sum(int(r["n"]) for r in rows)) + " (all settings)"
        elif len(rows) > 1 and rate.of(rows[1])[:2] == (k, n):
            decision, note = "tie with the runner-up", "a tie: keep the current setting"
            reason = cause_line(causes(best, objective), total)
        elif len(rows) == 1:
            decision, note = "keep", "one setting run: nothing compared"
            reason = cause_line(causes(best, objective), total)
        else:
            decision, note = "best swept setting (untested)", UNCONFIRMED
            reason = cause_line(causes(best, objective), total)
        shown = shown or rate.text(best)
        other_shown = other_shown or beside.text(best)
        answer = Answer(robot, arm, obj, decision, label, shown, other_shown, runner, reason)
        answers.append(replace(answer, note=note))
    return answers


def answer_table(answers: list[Answer], objective: str, title: str = "") -> Table:
    """The first screen's table (``HEADER``); the note says how the answers were reached."""
    rows = [
        [a.unit, a.decision, a.setting, a.rate, a.other_rate, a.runner_up, a.reason]
        for a in answers
    ]
    notes = sorted({a.note for a in answers if a.note})
    note = f"Ranked by the {objective} rate (--objective). " + " · ".join(notes)
    return Table(title or "Answer: which setting, how sure, why the rest fail", HEADER, rows, note)
