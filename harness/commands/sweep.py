"""``harness sweep SWEEP.yaml``: run a sweep with a progress bar, then print its summary."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from rich.console import Console

from harness.commands.console import make_console, say, styled, videos_possible
from harness.runs.limits import MAX_EPISODES, MAX_POINTS, error_rows_line, too_many_errors
from harness.runs.pace import pace_line
from harness.runs.sweep import run_sweep


def check_flags(args: argparse.Namespace) -> None:
    """Flags that would be silently ignored are usage errors (one line, exit 2)."""
    from harness.errors import HarnessError

    if args.sweep and args.resume:
        raise HarnessError(
            f"give a sweep YAML or --resume RUN_DIR, not both: --resume runs "
            f"{Path(args.resume) / 'sweep.yaml'} and would ignore {args.sweep}"
        )
    if not args.sweep and not args.resume:
        raise HarnessError("give a sweep YAML or --resume RUN_DIR")
    for flag, given in (("--force", args.force), ("--retry-errors", args.retry_errors)):
        if given and not args.resume:
            raise HarnessError(f"{flag} only applies with --resume RUN_DIR")
    if args.resume and args.out:
        raise HarnessError("--out does not apply with --resume (the run stays in RUN_DIR)")
    if args.address and args.backend != "ray":
        raise HarnessError(f"--address needs --backend ray (the backend is {args.backend})")
    if args.address:
        from harness.runs.ray_address import check_ray_address

        check_ray_address(args.address)  # before the run: one line, not 240 s of Ray retries


def main(args: argparse.Namespace) -> int:
    check_flags(args)
    args.videos = videos_possible(args.videos)  # before mujoco is imported
    console = make_console()
    if args.sweep:
        from harness.commands.validate import print_warnings, sweep_warning_lines
        from harness.config import load_sweep

        print_warnings(sweep_warning_lines(load_sweep(args.sweep), args.sweep))
    outcome = run_sweep(
        Path(args.sweep) if args.sweep else None,
        resume_dir=Path(args.resume) if args.resume else None,
        force=bool(getattr(args, "force", False)),
        max_episodes=args.max_episodes or MAX_EPISODES,
        max_points=args.max_points or MAX_POINTS,
        retry_errors=args.retry_errors,
        out=Path(args.out) if args.out else None,
        backend=args.backend,
        workers=args.workers,
        address=args.address,
        record=args.record,
        episodes_per_point=args.episodes_per_point,
        progress=not args.no_progress,
        share=False if getattr(args, "no_share", False) else None,
    )
    stats = outcome.stats
    from harness.report.finish import finish_run  # scipy, matplotlib: only after the run

    finish_run(outcome.run_dir, objective=args.objective, videos=args.videos)  # built once
    if outcome.skipped_existing:
        console.print(f"resumed: {outcome.skipped_existing} episode(s) were already done")
    console.print(
        f"{stats.finished} episode(s) in {stats.wall_time_s:.1f} s"
        + (f", {stats.crashed} worker crash(es) recorded as errors" if stats.crashed else "")
    )
    pace = pace_line(stats.arrivals, stats.wall_time_s)
    if pace is not None:
        console.print(pace)
    print_summary(outcome.run_dir, console)
    line = error_rows_line(outcome.errors, outcome.rows, outcome.run_dir)
    failing = too_many_errors(outcome.errors, outcome.rows)
    if line is not None:
        say(f"error: {line}" if failing else line, file=sys.stderr)
    if stats.interrupted:
        console.print(
            styled(
                "[yellow]interrupted[/]: finished episodes are kept; continue with "
                "harness sweep --resume {run_dir}",
                run_dir=outcome.run_dir,
            )
        )
        return 130
    return 1 if failing else 0


def _cell(value: object) -> str:
    """Compact cell text: ``["downward", 140.0]`` -> ``downward 140``."""
    import json

    if isinstance(value, str) and value.startswith("["):
        try:
            items = json.loads(value)
        except json.JSONDecodeError:
            return value
        return " ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in items)
    return str(value)


def _valid(row: Any) -> list[str]:
    """The valid rate beside the reference rate: ``v/m r%`` and its Wilson interval."""
    judged = int(row.get("n_judged", 0) or 0)
    if not judged:
        return ["", ""]
    return [
        f"{int(row['valid'])}/{judged} {row['valid_rate']:.0%}",
        f"{row['valid_ci_low']:.2f}–{row['valid_ci_high']:.2f}",
    ]


def print_summary(run_dir: Path, console: Console) -> None:
    """The per-point summary table and the paths of the report and the recording."""
    import pandas as pd
    from rich.table import Table

    summary_path = run_dir / "summary.csv"
    if summary_path.is_file():
        summary = pd.read_csv(summary_path)
        table = Table(title=f"success per point ({run_dir})")
        keys = [c for c in ("robot", "arm", "object") if c in summary.columns]
        # Swept keys, minus those the key columns already show (object.mesh -> object).
        params = [
            c
            for c in summary.columns
            if c.startswith("param.") and c not in ("param.object.mesh", "param.objects.0.mesh")
        ]
        for column in [*keys, *params]:
            table.add_column(column.removeprefix("param.").removeprefix("pick."))
        for column in ("n", "rate", "95% CI", "valid", "valid CI", "top failure"):
            table.add_column(column, justify="right")
        fail_columns = [c for c in summary.columns if c.startswith("fail.")]
        for _, cells in summary.iterrows():
            row: Any = cells  # the pandas stubs type a row's cell as a Series union
            fails = {c.removeprefix("fail."): int(row[c]) for c in fail_columns if row[c] > 0}
            top = max(fails, key=fails.__getitem__) if fails else ""
            table.add_row(
                *[_cell(row[c]) for c in [*keys, *params]],
                str(int(row["n"])),
                f"{row['rate']:.0%}" if row["n"] else "",  # n = 0: every row an error
                f"{row['wilson_lo']:.2f}–{row['wilson_hi']:.2f}" if row["n"] else "",
                *_valid(row),
                f"{top} ({fails[top]})" if top else "",
            )
        console.print(table)
        from harness.commands.report import print_answers
        from harness.report.objective import effective_objective, resolve_objective

        objective = effective_objective(summary, resolve_objective(run_dir, None))
        print_answers(console, summary, objective)  # the report's first screen, in short
        counts = summary["fallback"].tolist() if "fallback" in summary.columns else []
        if sum(counts):
            console.print(
                styled(
                    "[yellow]reference fallback[/] at {points} point(s) ({episodes} episodes): "
                    "the filter kept no candidate (report.html: ⚑)",
                    points=sum(c > 0 for c in counts),
                    episodes=sum(counts),
                ),
                soft_wrap=True,
            )
    for name in ("summary.csv", "episodes.csv", "report.md", "report.html", "recording.rrd"):
        path = run_dir / name
        if path.exists():
            console.print(f"  {name:14s} {path}")
    episodes_dir = run_dir / "episodes"
    if episodes_dir.is_dir():
        count = len(list(episodes_dir.glob("*.rrd")))
        console.print(f"  {'episodes/':14s} {count} episode recording(s) in {episodes_dir}")
