"""``harness tune TASK_OR_SWEEP...``: screen, race, decide; print the decisions and the keys."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from harness.commands.console import make_console, styled
from harness.errors import HarnessError
from harness.tuning.run import TuneOptions, analyse, lines, tune

BUDGET = re.compile(r"^\d+(\.\d+)?s$|^\d+$")


def main(args: argparse.Namespace) -> int:
    console = make_console()
    write = Path(args.write) if args.write else None
    if args.budget and not BUDGET.match(args.budget):
        raise HarnessError(f"--budget {args.budget!r}: expected episodes (400) or seconds (300s)")
    if args.analyse:
        result = analyse(Path(args.analyse), args.objective, write)
    elif not args.files:
        raise HarnessError("give task or sweep files, or --analyse DIR")
    else:
        options = TuneOptions(
            objective=args.objective,
            screen_seeds=args.episodes or TuneOptions.screen_seeds,
            top=args.top,
            block=args.block,
            max_seeds=args.max_seeds,
            budget=args.budget,
            engine=args.engine,
        )
        result = tune(
            [Path(f) for f in args.files],
            step=args.step,
            bands=args.bands,
            out=Path(args.out) if args.out else None,
            seed=args.seed,
            options=options,
            workers=args.workers,
            progress=True,
            write=write,
        )
    if result.interrupted and result.decisions.empty:
        console.print(
            styled(
                "[yellow]interrupted[/]: finished episodes are kept; run the same harness tune "
                "command with --out {run_dir} to continue",
                run_dir=result.run_dir,
            )
        )
        return 130
    console.print(result.yaml_text, highlight=False, markup=False, soft_wrap=True)
    for line in lines(result.decisions):
        console.print(line, highlight=False, markup=False, soft_wrap=True)
    rows = [("tuned", result.tuned_yaml), ("report", result.tuned_md), ("run", result.run_dir)]
    rows += [("written", path) for path in result.written]
    for label, path in rows:
        console.print(f"  {label:9s} {path}", soft_wrap=True, highlight=False)
    return 130 if result.interrupted else 0
