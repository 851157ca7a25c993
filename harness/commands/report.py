"""``harness report RUN_DIR`` and ``harness compare RUN_A RUN_B [--csv FILE]``."""

from __future__ import annotations

import argparse
import contextlib
import math
from pathlib import Path
from typing import Any

import pandas as pd
from rich.console import Group
from rich.table import Table
from rich.text import Text

from harness.commands.console import make_console, videos_possible, visible
from harness.commands.summary_table import summary_table
from harness.report import (
    build_report,
    compare_runs,
    format_value,
    varying_params,
)
from harness.report.answer import sweep_answers
from harness.report.current import current_settings
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
    summary = pd.read_csv(paths.summary_csv)
    console.print(summary_table(summary, paths.objective))
    print_answers(console, summary, paths.objective, run_dir)
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


def print_answers(
    console: Any, summary: pd.DataFrame, objective: str, run_dir: Path | None = None
) -> None:
    """The first screen's answers, one line per robot, arm and object (``run_dir``: where the
    tasks' own settings are read, what a tie keeps)."""
    params = setting_params(summary)  # an object axis alone is no setting (mesh=banana)
    current = current_settings(run_dir, summary) if run_dir is not None else None
    for answer in sweep_answers(summary, objective, params, current):
        console.print(answer_block(answer))
    console.print(
        f"ranked by the {objective} rate; a best swept setting is not confirmed on fresh "
        "seeds: harness tune",
        soft_wrap=True,
    )


# The decision's colour: green is for a tested switch only (harness.report.tune_link); a
# candidate chosen on the sweep's own seeds is cyan, no clear winner and keep are uncoloured.
DECISION_STYLES = (("switch", "green"), ("best swept", "cyan"), ("no setting", "red"))


def answer_block(answer: Any) -> Group:
    """One unit's answer in a few wrapped lines: the decision first, then the setting, its
    rates, the others compared and why the rest miss (fits any width, cuts nothing)."""
    style = next((s for prefix, s in DECISION_STYLES if answer.decision.startswith(prefix)), "")
    rows = Table.grid(padding=(0, 1))
    rows.add_column(no_wrap=True)
    rows.add_column(overflow="fold")
    head = Text(visible(answer.unit), style="bold")
    head.append(": ").append(answer.decision, style=style)
    for label, text in (
        ("  setting", answer.setting),
        ("  rate", f"{answer.rate} · {answer.other_rate}"),
        ("  others", answer.runner_up),
        ("  why", answer.reason),
    ):
        rows.add_row(label, text)
    return Group(head, rows)


def _short(column: str) -> str:
    """``param.pick.approach_filter`` -> ``approach_filter`` (the last part of the key)."""
    return column.split(".")[-1]


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
