"""Per-object results of a template tune, and the exceptions that pay.

After a template group's race decides its setting (the chosen one for a switch, else the current
one: the *template*), each object is looked at on its own:

- its rate under the current and the chosen template on the race's fresh seeds (few per object:
  the pooled test is the evidence, these rows say where the pooled rate comes from);
- an **exception candidate** when its own best screening setting (non-fallback) screened better
  on it than the template did. Every candidate is tested on ``exception_seeds`` fresh paired seeds
  of its own (sweep seed + :data:`EXCEPTION_SEED_OFFSET`: neither the screening's, the race's
  nor a check's default seeds) against the template, by the exact one-sided McNemar test, with
  Holm's correction over the group's candidates at one-sided alpha. A rejected hypothesis is an
  **override** (that object's file gets its own setting); anything else is not: no override
  without that confirmation;
- **no setting helps** when no setting screened a single success on it and the template
  succeeded on none of its race seeds; its dominant cause is read from its race rows
  (``harness.tuning.causes``: reach with the joint at its limit, slip, the filter leaving no
  candidate so the reference's fallback ran, the table).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from harness.config import SweepConfig, TaskConfig
from harness.report.frames import column, frame_of, series_rows
from harness.tuning.analysis import ranked
from harness.tuning.causes import cause_sentence
from harness.tuning.decide import (
    SWITCH,
    UNDECIDED,
    Racer,
    UnitRace,
    discordant,
    holm,
    one_sided_mcnemar,
    rate_bounds,
)
from harness.tuning.decisions import object_name, setting_label
from harness.tuning.options import TuneOptions
from harness.tuning.race import Budget, RaceLog, RaceRunner, Unit, run_race
from harness.tuning.sequential import Plan

EXCEPTION_SEED_OFFSET = 300_000
EXCEPTIONS_DIR = "exceptions"
OVERRIDE = "override"
NOT_CONFIRMED = "tested, not confirmed"


@dataclass
class ExceptionTest:
    """One object's own best setting against its group's template on seeds of its own."""

    group: str
    task: str
    context: str
    template: Racer
    best: Racer
    p_value: float = math.nan
    p_holm: float = math.nan
    confirmed: bool = False
    rows: list[dict[str, Any]] = field(default_factory=list)


def template_of(row: dict[str, Any]) -> tuple[str, str]:
    """A group's decided setting: the chosen one for a switch, else the current one."""
    if row["verdict"] == SWITCH:
        return str(row["approach"]), str(row["facing"])
    return str(row["current_approach"]), str(row["current_facing"])


def candidates(
    unit: Unit, template: tuple[str, str], success: pd.DataFrame
) -> list[tuple[tuple[str, str], tuple[str, str]]]:
    """The group's members (task, context) whose own best screening setting beat the template
    on them."""
    out = []
    for task, context in unit.members:
        rows = frame_of(success[(success["task"] == task) & (success["context"] == context)])
        if not len(rows):
            continue
        best = ranked(rows, template).iloc[0]
        setting = (str(best["approach"]), str(best["facing"]))
        at = frame_of(rows[(rows["approach"] == template[0]) & (rows["facing"] == template[1])])
        base = float(column(at, "rate").iloc[0]) if len(at) else 0.0
        if setting != template and float(best["rate"]) > base:
            out.append(((task, context), setting))
    return out


def exception_tests(
    units: list[Unit], decisions: pd.DataFrame, success: pd.DataFrame, log: RaceLog, why: str
) -> list[ExceptionTest]:
    """Per decided template group, its objects whose own best screening setting beat the
    template (``harness.tuning.exceptions``); none while the race is cut short."""
    if why or log.interrupted:
        return []
    tests = []
    for unit in units:
        if not unit.is_template:
            continue
        row = decisions[(decisions["task"] == unit.task) & (decisions["context"] == unit.context)]
        decided = row.iloc[0].to_dict()
        if decided["verdict"] == UNDECIDED:
            continue
        template = template_of(decided)
        for (task, context), best in candidates(unit, template, success):
            tests.append(
                ExceptionTest(unit.task, task, context, Racer(template, 0), Racer(best, 1))
            )
    return tests


def run_exceptions(
    out: Path,
    sweep: SweepConfig,
    tasks: list[TaskConfig],
    tests: list[ExceptionTest],
    options: TuneOptions,
    *,
    backend: str,
    workers: int,
    may_run: bool,
    progress: bool = False,
    announce: Callable[[str], None] | None = None,
) -> RaceLog:
    """Run every test's two settings on ``exception_seeds`` paired fresh seeds (one round in
    ``out/exceptions``), then Holm over each group's tests."""
    if not tests:
        return RaceLog()
    seeds = options.exception_seeds
    units = []
    for test in tests:
        plan = Plan(seeds, seeds, options.alpha, 1, options.target_gain)
        units.append(Unit(test.task, test.context, UnitRace([test.template, test.best], plan)))
    runner = RaceRunner(
        out / EXCEPTIONS_DIR,
        sweep,
        tasks,
        seeds,
        objective=options.objective,
        backend=backend,
        workers=workers,
        may_run=may_run,
        progress=progress,
        seconds_each=options.seconds_each,
        announce=announce,
        seed_offset=EXCEPTION_SEED_OFFSET,
        name="exceptions",
    )
    runner.round_label = "exception tests"
    log = run_race(units, runner, Budget())
    for test, unit in zip(tests, units, strict=True):
        test.rows = unit.rows
    if not (log.interrupted or log.missing):
        decide_exceptions(tests, seeds, options.alpha)
    return log


def decide_exceptions(tests: list[ExceptionTest], seeds: int, alpha: float) -> None:
    """Per group, the exact one-sided McNemar p-value of each test that ran all ``seeds``
    (its own best better than the template), Holm over the group's tests at ``alpha``: a
    rejection with more successes is a confirmed override. A test short of its seeds (an
    interrupted run) decides nothing."""
    for group in dict.fromkeys(t.group for t in tests):
        mine = [t for t in tests if t.group == group and len(t.best.outcomes) == seeds]
        if not mine:
            continue
        p_values = [
            float(one_sided_mcnemar(*discordant(t.best.outcomes, t.template.outcomes)))
            for t in mine
        ]
        rejected, adjusted = holm(p_values, alpha)
        for test, p, p_adj, ok in zip(mine, p_values, adjusted, rejected, strict=True):
            test.p_value, test.p_holm = p, p_adj
            test.confirmed = bool(ok and test.best.successes > test.template.successes)


def _share(racer: Racer | None, member: tuple[str, str]) -> tuple[int, int]:
    """A racer's successes and seeds on one member of its template."""
    if racer is None:
        return 0, 0
    key = f"{member[0]}\t{member[1]}"
    picked = [o for o, s in zip(racer.outcomes, racer.strata, strict=False) if s == key]
    return int(sum(picked)), len(picked)


def _in(row: dict[str, Any], context: str) -> bool:
    """Whether a race row's point has ``context``'s values (its object among them)."""
    others = json.loads(context)
    point = row.get("point")
    values = json.loads(point) if isinstance(point, str) and point else {}
    return all(values.get(k) == v for k, v in others.items())


def _exception_fields(test: ExceptionTest | None) -> dict[str, Any]:
    """An object's exception test columns (zeros and NaN when it was not tested)."""
    return {
        "exception_n": len(test.best.outcomes) if test else 0,
        "exception_successes": test.best.successes if test else 0,
        "exception_template_successes": test.template.successes if test else 0,
        "exception_lo": rate_bounds(test.best)[0] if test and test.best.outcomes else math.nan,
        "exception_hi": rate_bounds(test.best)[1] if test and test.best.outcomes else math.nan,
        "only_own_best": discordant(test.best.outcomes, test.template.outcomes)[0] if test else 0,
        "only_template": discordant(test.best.outcomes, test.template.outcomes)[1] if test else 0,
        "p": test.p_value if test else math.nan,
        "p_holm": test.p_holm if test else math.nan,
    }


def objects_table(
    units: list[Unit],
    decisions: pd.DataFrame,
    success: pd.DataFrame,
    tests: list[ExceptionTest],
    labels: dict[str, str],
    objective: str,
) -> pd.DataFrame:
    """``objects.csv``: per template group and object, its rates under the current and the
    chosen template on the race's seeds, its own best screening setting, its exception test and
    whether no setting helps (with the cause)."""
    by_member = {(t.task, t.context): t for t in tests}
    rows = []
    for unit in units:
        if not unit.is_template:
            continue
        decided = decisions[
            (decisions["task"] == unit.task) & (decisions["context"] == unit.context)
        ]
        row = decided.iloc[0].to_dict()
        template = template_of(row)
        chosen = next((r for r in unit.race.racers if r.setting == template), None)
        current = unit.race.current
        for task, context in unit.members:
            member = (task, context)
            screen = frame_of(success[(success["task"] == task) & (success["context"] == context)])
            best = ranked(screen, template).iloc[0] if len(screen) else None
            at = frame_of(
                screen[(screen["approach"] == template[0]) & (screen["facing"] == template[1])]
            )
            cur_k, cur_n = _share(current, member)
            tpl_k, tpl_n = _share(chosen, member)
            test = by_member.get(member)
            object_rows = [r for r in unit.rows if r.get("task") == task and _in(r, context)]
            most = float(column(screen, "successes").max()) if len(screen) else math.nan
            helpless = bool(most == 0 and tpl_n and tpl_k == 0)
            verdict = ""
            if test is not None and test.best.outcomes:
                verdict = OVERRIDE if test.confirmed else NOT_CONFIRMED
            rows.append(
                {
                    "group": unit.task,
                    "context": context,
                    "task": task,
                    "object": object_name(context, labels.get(task, task)),
                    "template": setting_label(template),
                    "verdict": row["verdict"],
                    "current_successes": cur_k,
                    "current_n": cur_n,
                    "current_rate": cur_k / cur_n if cur_n else math.nan,
                    "template_successes": tpl_k,
                    "template_n": tpl_n,
                    "template_rate": tpl_k / tpl_n if tpl_n else math.nan,
                    "screen_template_rate": float(column(at, "rate").iloc[0])
                    if len(at)
                    else math.nan,
                    "own_best": setting_label((str(best["approach"]), str(best["facing"])))
                    if best is not None
                    else "",
                    "own_best_approach": str(best["approach"]) if best is not None else "",
                    "own_best_facing": str(best["facing"]) if best is not None else "",
                    "screen_own_best_rate": float(best["rate"]) if best is not None else math.nan,
                    "exception": verdict,
                    **_exception_fields(test),
                    "no_setting_helps": helpless,
                    "cause": cause_sentence(object_rows, objective) if helpless else "",
                }
            )
    table = pd.DataFrame(rows)
    if len(table):
        table = table.sort_values(
            ["group", "template_rate"], ascending=[True, False], kind="stable"
        )
    return table.reset_index(drop=True)


def object_lines(objects: pd.DataFrame) -> list[str]:
    """The terminal's lines per template group: overrides, tests not confirmed, objects no
    setting helps (each with its cause)."""
    out = []
    if not len(objects):
        return out
    for group, rows in objects.groupby("group", sort=False):
        rows = frame_of(rows).assign(exception=lambda t: t["exception"].fillna("").astype(str))
        tested = frame_of(rows[rows["exception"] != ""])
        confirmed = frame_of(rows[rows["exception"] == OVERRIDE])
        helpless = frame_of(rows[rows["no_setting_helps"].astype(bool)])
        line = (
            f"{group}: {len(rows)} objects; {len(tested)} tested for an exception on "
            f"{int(column(tested, 'exception_n').max()) if len(tested) else 0} seeds of their "
            "own, "
            f"{len(confirmed)} confirmed (Holm over the {len(tested)})"
        )
        out.append(line)
        for row in series_rows(confirmed):
            out.append(
                f"  override {row['object']}: {row['own_best']} "
                f"{row['exception_successes']}/{row['exception_n']} against the template's "
                f"{row['exception_template_successes']}/{row['exception_n']} "
                f"(+{row['only_own_best']}/-{row['only_template']}, Holm p {row['p_holm']:.2g})"
            )
        for row in series_rows(frame_of(tested[tested["exception"] == NOT_CONFIRMED])):
            out.append(
                f"  not confirmed {row['object']}: {row['own_best']} "
                f"{row['exception_successes']}/{row['exception_n']} against "
                f"{row['exception_template_successes']}/{row['exception_n']} "
                f"(Holm p {row['p_holm']:.2g}): keeps the template"
            )
        for row in series_rows(helpless):
            out.append(f"  no setting helps {row['object']}: {row['cause']}")
    return out


def objects_markdown(objects: pd.DataFrame, images: dict[str, Path]) -> list[str]:
    """``tuned.md``'s part per template group: the objects table and the picture."""
    from harness.markdown import markdown_table

    parts: list[str] = []
    if not len(objects):
        return parts
    for group, rows in objects.groupby("group", sort=False):
        parts += ["", f"## Objects of template group {group}", ""]
        image = images.get(str(group))
        if image is not None:
            parts += [f"![objects]({image.name})", ""]
        table = []
        for row in series_rows(rows):
            table.append(
                [
                    row["object"],
                    f"{row['current_successes']}/{row['current_n']}",
                    f"{row['template_successes']}/{row['template_n']}",
                    row["own_best"],
                    f"{row['screen_own_best_rate']:.0%} vs {row['screen_template_rate']:.0%}",
                    row["exception"]
                    + (f" (Holm p {row['p_holm']:.2g})" if row["exception"] else ""),
                    row["cause"] if bool(row["no_setting_helps"]) else "",
                ]
            )
        columns = [
            "object",
            "current (race seeds)",
            "template (race seeds)",
            "own best (screening)",
            "own best vs template (screening)",
            "exception",
            "no setting helps: cause",
        ]
        parts += markdown_table(columns, table)
    return parts
