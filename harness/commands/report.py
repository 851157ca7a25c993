"""``harness report RUN_DIR`` and ``harness compare RUN_A RUN_B [--csv FILE]``."""

from __future__ import annotations

import argparse
import contextlib
import math
from pathlib import Path
from typing import Any

import pandas as pd
from rich.table import Table
from rich.text import Text

from harness.commands.console import make_console, styled, videos_possible
from harness.report import (
    FAIL_PREFIX,
    build_report,
    compare_runs,
    format_value,
    varying_params,
)
from harness.report.answer import sweep_answers
from harness.report.frames import column as column_of
from harness.report.frames import frame_of, series_rows
from harness.report.tables import setting_params
from harness.writes import write_through

SIGNIFICANCE = 0.05


def run_lock(run_dir: Path) -> contextlib.AbstractContextManager[object]:
    """The run directory's lock (``RunLock``: one line naming the holder's pid if a sweep
    holds it); nothing for a path that is not a real folder (``build_report`` names it)."""
    from harness.runs.safety import RunLock

    if run_dir.is_dir() and not run_dir.is_symlink():
        return RunLock(run_dir)
    return contextlib.nullcontext()


def main(args: argparse.Namespace) -> int:
    """Rebuild summary, plots and report of a run directory; print the summary and the paths."""
    run_dir = Path(args.run_dir)
    args.videos = videos_possible(args.videos)  # before mujoco is imported
    console = make_console()
    if args.videos:
        console.print("replaying one success and one failure per robot arm for the videos ...")
    with run_lock(run_dir):  # a sweep still filling the directory: refused, not raced
        paths = build_report(run_dir, export=True, objective=args.objective, videos=args.videos)
    console.print(summary_table(pd.read_csv(paths.summary_csv), f"success per point ({run_dir})"))
    print_answers(console, pd.read_csv(paths.summary_csv), paths.objective)
    for label, path in (
        ("summary", paths.summary_csv),
        ("best", paths.best_csv),
        ("report", paths.report_md),
        ("html", paths.report_html),
        ("plots", paths.run_dir / "plots"),
        *([("videos", paths.run_dir / "videos")] if paths.videos else []),
    ):
        console.print(f"  {label:8s} {path}", soft_wrap=True, highlight=False)
    return 0


def print_answers(console: Any, summary: pd.DataFrame, objective: str) -> None:
    """The first screen's answers, one line per robot, arm and object."""
    params = setting_params(summary) or varying_params(summary)
    for answer in sweep_answers(summary, objective, params):
        console.print(
            styled(
                "best for [bold]{unit}[/]: {rest}",
                unit=answer.unit,
                rest=f"{answer.decision} — {answer.setting}: {answer.rate} · {answer.other_rate}; "
                f"runner-up {answer.runner_up}; {answer.reason}",
            ),
            soft_wrap=True,
        )
    console.print(
        f"ranked by the {objective} rate; a best swept setting is not confirmed on fresh "
        "seeds: harness tune",
        soft_wrap=True,
    )


def _short(column: str) -> str:
    """``param.pick.approach_filter`` -> ``approach_filter`` (the last part of the key)."""
    return column.split(".")[-1]


def valid_cells(row: Any) -> list[str]:
    """``valid k/m``, its rate and Wilson interval; blank when no episode was judged."""
    judged = int(row.get("n_judged", 0) or 0)
    if not judged:
        return ["", "", ""]
    return [
        f"{int(row['valid'])}/{judged}",
        f"{row['valid_rate']:.0%}",
        f"{row['valid_ci_low']:.2f}–{row['valid_ci_high']:.2f}",
    ]


def summary_table(summary: pd.DataFrame, title: str) -> Table:
    """The per-point summary as a rich table (robot, arm, object, swept values, rate, CI)."""
    params = [c for c in summary.columns if c.startswith("param.")]
    shown = setting_params(summary) or varying_params(summary) or params
    table = Table(title=title)
    for column in ("robot", "arm", "object", *[_short(p) for p in shown]):
        table.add_column(column)
    for column in ("k/n", "rate", "95% CI", "valid", "valid rate", "valid CI", "top failure"):
        table.add_column(column, justify="right")
    fail_columns = [c for c in summary.columns if c.startswith(FAIL_PREFIX)]
    for row in series_rows(summary):
        fails = {c.removeprefix(FAIL_PREFIX): int(row[c]) for c in fail_columns if row[c] > 0}
        top = max(sorted(fails), key=fails.__getitem__) if fails else ""
        table.add_row(
            str(row["robot"]),
            str(row["arm"]),
            str(row["object"]),
            *[format_value(row[p]) for p in shown],
            f"{int(row['successes'])}/{int(row['n'])}",
            f"{row['rate']:.0%}" if row["n"] else "",
            f"{row['wilson_lo']:.2f}–{row['wilson_hi']:.2f}" if row["n"] else "",
            *valid_cells(row),
            f"{top} ({fails[top]})" if top else "",
        )
    return table


def _verdict(comparison: pd.DataFrame, objective: str) -> str:
    """The verdict compared (``valid`` falls back to reference when no row was judged)."""
    if "verdict" in comparison and len(comparison):
        return str(comparison["verdict"].iloc[0])
    return objective


def compare(args: argparse.Namespace) -> int:
    """Per-setting success-rate differences between two runs: McNemar on shared seeds, else a
    two-proportion test (``harness.report.compare``)."""
    comparison = compare_runs(Path(args.run_a), Path(args.run_b), args.match, args.objective)
    console = make_console()
    by_arm = bool(len(comparison)) and comparison["match"].iloc[0] == "arm"
    params = [] if by_arm else (
        varying_params(comparison) or [c for c in comparison.columns if c.startswith("param.")]
    )  # fmt: skip
    shown = ["filters_a", "filters_b"] if by_arm else params
    what = "robot, arm and object" if by_arm else "setting"
    table = Table(
        title=f"B - A per {what} ({_verdict(comparison, args.objective)} rate)   "
        f"A = {args.run_a}   B = {args.run_b}"
    )
    for column in ("robot", "arm", "object", *[_short(p) for p in shown]):
        table.add_column(column)
    for column in ("A", "B", "B - A", "p", "test", "pairs"):
        table.add_column(column, justify="right")
    for row in series_rows(comparison):
        a = f"{row['successes_a']}/{row['n_a']}" if row["n_a"] else "—"
        b = f"{row['successes_b']}/{row['n_b']}" if row["n_b"] else "—"
        if row["present"] == "both":
            difference = f"{row['difference']:+.0%}"
            p_value = row["p_value"]
            p_text = f"{p_value:.3g}" if not math.isnan(p_value) else ""
            if not math.isnan(p_value) and p_value < SIGNIFICANCE:
                difference = Text(difference, style="bold")
                p_text = Text(p_text, style="bold")
        else:
            difference, p_text = row["present"], ""
        table.add_row(
            str(row["robot"]),
            str(row["arm"]),
            str(row["object"]),
            *[format_value(row[p]) for p in shown],
            a,
            b,
            difference,
            p_text,
            str(row["test"]),
            str(row["pairs"]) if row["test"] == "mcnemar" else "",
        )
    console.print(table)
    both = frame_of(comparison[comparison["present"] == "both"])
    significant = int((column_of(both, "p_value") < SIGNIFICANCE).sum())
    console.print(
        f"{len(both)} matched {what}(s), {significant} with p < {SIGNIFICANCE} "
        f"(not corrected for multiple comparisons)",
        soft_wrap=True,
    )
    if args.csv:
        path = Path(args.csv)
        write_through(path, lambda tmp: comparison.to_csv(tmp, index=False))
        console.print(f"  csv      {path}", soft_wrap=True, highlight=False)
    return 0
