"""A run's report and ``harness tune``: the tune's decisions on the page of its own runs, and
links from a sweep's page to tunes of the same tasks.

A tune writes ``<out>/tune.json`` (its options), ``<out>/screen`` and ``<out>/confirm`` (run
directories) and ``<out>/tune/decisions.csv`` (one row per robot, arm and object; its columns
grow with the tune, so every column is shown as it comes). The report of ``<out>/screen`` (or
``confirm``) is the tune's page: its decisions come first. A sweep's report links to tunes next
to it (``<reports>/*/tune.json``) whose tasks are among the run's.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from harness.report.answer import NO_SETTING, Answer
from harness.report.frames import series_rows
from harness.report.objective import DEFAULT_OBJECTIVE, REFERENCE, other
from harness.report.sections import Table

OPTIONS_FILE, DECISIONS = "tune.json", Path("tune") / "decisions.csv"
CHECK = Path("check") / "check.csv"  # harness tune --check, in its default directory
RUN_PARTS = ("screen", "confirm")  # the tune's run directories
MAX_SIBLINGS = 200  # tune folders looked at next to a run, at most


@dataclass(frozen=True)
class Tune:
    """One tune: its folder, options and decisions."""

    path: Path
    options: dict[str, Any]
    decisions: pd.DataFrame

    @property
    def objective(self) -> str:
        return str(self.options.get("objective") or DEFAULT_OBJECTIVE)

    @property
    def tasks(self) -> set[str]:
        """The task names the tune decided on."""
        if "task" in self.decisions:
            return {str(t) for t in self.decisions["task"]}
        return set(self.options.get("sources", {}))

    def page(self) -> Path:
        return self.path / "screen" / "report.html"

    def markdown(self) -> Path:
        return self.path / "tune" / "tuned.md"


def load_tune(path: Path) -> Tune | None:
    """The tune at ``path`` when it has options and decisions, else None."""
    options_path, decisions_path = path / OPTIONS_FILE, path / DECISIONS
    if not options_path.is_file() or not decisions_path.is_file():
        return None
    try:
        options = json.loads(options_path.read_text(encoding="utf-8"))
        decisions = pd.read_csv(decisions_path)
    except (OSError, ValueError, pd.errors.EmptyDataError):
        return None
    return Tune(path, options if isinstance(options, dict) else {}, decisions)


def own_tune(run_dir: Path) -> Tune | None:
    """The tune whose screening or race ``run_dir`` is."""
    run_dir = Path(run_dir).resolve()
    return load_tune(run_dir.parent) if run_dir.name in RUN_PARTS else None


def related_tunes(run_dir: Path, tasks: set[str]) -> list[Tune]:
    """Tunes next to ``run_dir`` (same parent folder) that decided on some of ``tasks``."""
    parent = Path(run_dir).resolve().parent
    found = []
    try:
        candidates = sorted(parent.glob(f"*/{OPTIONS_FILE}"))[:MAX_SIBLINGS]
    except OSError:
        return []
    for options in candidates:
        tune = load_tune(options.parent)
        if tune is not None and tune.tasks & tasks:
            found.append(tune)
    return found


def relative(target: Path, start: Path) -> str:
    """A link from a page in ``start`` to ``target`` (POSIX separators)."""
    return Path(os.path.relpath(target.resolve(), start.resolve())).as_posix()


def _number(value: Any) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        return math.nan
    return number


def _int(value: Any) -> int | None:
    number = _number(value)
    return None if math.isnan(number) else int(number)


def _decision(row: Any) -> str:
    verdict = str(row.get("verdict", "") or "")
    cause = str(row.get("cause", "") or "") if not _blank(row.get("cause")) else ""
    needed = _int(row.get("seeds_needed"))
    if verdict.startswith("switch"):
        return "switch (confirmed on fresh seeds)"
    if verdict.startswith("undecided") and needed:
        return f"undecided: needs {needed} seeds"
    if verdict.startswith(NO_SETTING) and cause and cause not in verdict:
        return f"{verdict}: {cause}"
    if verdict.startswith("keep"):
        return "keep current"
    return verdict or "?"


def _blank(value: Any) -> bool:
    return value is None or (isinstance(value, float) and math.isnan(value)) or str(value) == ""


def _rate(row: Any, objective: str, prefix: str = "") -> str:
    k, n = _int(row.get(f"{prefix}successes")), _int(row.get(f"{prefix}n"))
    rate = _number(row.get(f"{prefix}rate"))
    lo, hi = _number(row.get(f"{prefix}lo")), _number(row.get(f"{prefix}hi"))
    if not n or k is None:
        return f"{objective}: no fresh seeds"
    ci = "" if math.isnan(lo) else f", {lo:.2f}–{hi:.2f}"
    return f"{objective} {k}/{n} ({rate:.0%}{ci})"


def tune_answers(tune: Tune) -> list[Answer]:
    """One answer per decision row, read from whatever columns the row has."""
    objective = tune.objective
    answers = []
    for row in series_rows(tune.decisions):
        reference = _number(row.get("reference_rate"))
        beside = (
            f"reference {reference:.0%}"
            if objective != REFERENCE and not math.isnan(reference)
            else f"{other(objective)}: not measured in the race"
        )
        verdict = str(row.get("verdict", "") or "")
        contenders = "" if _blank(row.get("contenders")) else str(row["contenders"])
        if verdict.startswith("switch"):
            runner = f"current: {_rate(row, objective, 'current_')}"
        else:
            runner = contenders or "none confirmed better"
        reason = "" if _blank(row.get("reason")) else str(row["reason"])
        notes = [f"{_int(row.get('n')) or 0} fresh seeds"]
        for name in row.index:
            if "detect" in str(name) and not _blank(row[name]):
                notes.append(f"{name}: {_format(row[name])}")
        answers.append(
            Answer(
                str(row.get("robot", "")),
                str(row.get("arm", "")),
                str(row.get("object", "")),
                _decision(row),
                str(row.get("setting", "")),
                _rate(row, objective),
                beside,
                runner,
                "; ".join(p for p in (reason, *notes) if p),
            )
        )
    return answers


def _format(value: Any) -> str:
    if isinstance(value, float):
        return "" if math.isnan(value) else f"{value:.3g}"
    return str(value)


def decisions_table(tune: Tune) -> Table:
    """Every column of ``decisions.csv``, as it comes."""
    frame = tune.decisions
    return Table(
        "Tune decisions: every column of decisions.csv",
        [str(c) for c in frame.columns],
        [[_format(v) for v in row.tolist()] for row in series_rows(frame)],
        f"{tune.path / DECISIONS}: rates on the race's fresh seeds only (objective "
        f"{tune.objective}); docs/tune.md explains each column.",
    )


def _fraction(k: Any, n: Any, lo: Any, hi: Any) -> str:
    return f"{int(k)}/{int(n)} ({float(lo):.2f}-{float(hi):.2f})" if int(n) else "-"


def check_rows(table: pd.DataFrame) -> tuple[list[str], list[list[str]]]:
    """The check's compact table (header, rows) for the terminal and ``check.md``."""
    header = [
        "unit",
        "tune",
        "tested",
        "current",
        "tested rate",
        "+/-",
        "p (Holm)",
        "verdict",
        "in tune CI",
    ]
    rows = []
    units = [f"{r['robot']} {r['arm']} {r['object']}" for r in series_rows(table)]
    for unit, row in zip(units, series_rows(table), strict=True):
        if units.count(unit) > 1:  # two task files of one robot, arm and object
            unit = f"{unit} ({row['task']})"
        inside, p = row["inside_tune_interval"], _number(row["p_holm"])
        tested = "" if _blank(row["setting"]) else str(row["setting"])
        rows.append(
            [
                unit,
                str(row["tune_verdict"]),
                tested or "-",
                _fraction(row["current_successes"], row["n"], row["current_lo"], row["current_hi"]),
                _fraction(row["successes"], row["n"], row["lo"], row["hi"]) if tested else "-",
                f"+{row['only_new']}/-{row['only_current']}",
                "-" if math.isnan(p) else f"{p:.2g}",
                str(row["verdict"]),
                "-" if _blank(inside) else ("yes" if str(inside) == "True" else "no"),
            ]
        )
    return header, rows


def check_table(tune: Tune) -> Table | None:
    """The tune's decisions tested on fresh seeds (``harness tune --check`` in its default
    directory, ``<tune>/check``), when it ran."""
    path = tune.path / CHECK
    try:
        frame = pd.read_csv(path) if path.is_file() else None
        header, rows = check_rows(frame) if frame is not None else ([], [])
    except (OSError, ValueError, KeyError, pd.errors.EmptyDataError):
        return None
    if not rows:
        return None
    return Table(
        "Tune decisions checked on fresh seeds (harness tune --check)",
        header,
        rows,
        f"{path}: the current setting against the tuned one (switch) or the race's best "
        "challenger, on seeds neither the screening nor the race used; exact McNemar, Holm over "
        "the units (docs/tune.md).",
    )


OBJECTS = Path("tune") / "objects.csv"  # a template tune's objects (harness.tuning.exceptions)


def objects_tables(tune: Tune) -> list[Table]:
    """Per template group of the tune, its objects sorted by the rate under the decided
    template, the exceptions and the objects no setting helps marked."""
    path = tune.path / OBJECTS
    try:
        frame = pd.read_csv(path) if path.is_file() else None
    except (OSError, ValueError, pd.errors.EmptyDataError):
        return []
    if frame is None or frame.empty or "group" not in frame:
        return []
    tables = []
    header = ["object", "current template", "decided template", "own best (screening)", "mark"]
    for group, rows in frame.groupby("group", sort=False):
        body = []
        for row in series_rows(rows):
            mark = ""
            if str(row.get("exception")) == "override":
                mark = f"exception: override (Holm p {_format(row.get('p_holm'))})"
            elif str(row.get("exception")) not in ("", "nan"):
                mark = f"exception {row['exception']} (Holm p {_format(row.get('p_holm'))})"
            if str(row.get("no_setting_helps")) == "True":
                mark = f"no setting helps: {row.get('cause', '')}"
            body.append(
                [
                    str(row["object"]),
                    f"{_int(row['current_successes'])}/{_int(row['current_n'])}",
                    f"{_int(row['template_successes'])}/{_int(row['template_n'])}",
                    f"{row['own_best']} ({_number(row['screen_own_best_rate']):.0%} vs "
                    f"{_number(row['screen_template_rate']):.0%})",
                    mark,
                ]
            )
        tables.append(
            Table(
                f"Template group {group}: every object under the current and the decided template",
                header,
                body,
                f"{path}: rates on the race's fresh seeds (few per object: the pooled test is "
                "the evidence); an exception is tested on seeds of its own, Holm over the "
                f"group's objects; picture: tune/objects_{group}.png",
            )
        )
    return tables
