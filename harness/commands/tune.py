"""``harness tune TASK_OR_SWEEP...``: screen, race, decide; print the decisions and the keys."""

from __future__ import annotations

import argparse
from dataclasses import asdict
from pathlib import Path
from typing import Any

from harness.commands.console import make_console, styled
from harness.errors import HarnessError
from harness.interndata.substitutes import parse_object_substitutions
from harness.tuning.exceptions import object_lines
from harness.tuning.race import Budget
from harness.tuning.run import OPTIONS_FILE, TuneOptions, analyse, lines, tune


def _options(args: argparse.Namespace) -> TuneOptions:
    """The tune's options: the flags given, else those stored in ``--out``'s tune.json (a
    rerun continues its race), else the defaults."""
    stored = TuneOptions()
    path = Path(args.out) / OPTIONS_FILE if args.out else None
    if path is not None and path.is_file():
        stored = TuneOptions.load(path)
    given = {
        "objective": args.objective,
        "screen_seeds": args.episodes,
        "top": args.top,
        "block": args.block,
        "max_seeds": args.max_seeds,
        "budget": args.budget,
        "coarse": None if args.directions is None else args.directions == "all",
        "exception_seeds": args.exception_seeds,
        "template": args.template,
    }
    base = {
        k: v
        for k, v in asdict(stored).items()
        if k not in ("sources", "plans", "seconds_each", "groups", "pick_paths")
    }
    base["budget"] = None  # a budget is this invocation's, never carried over
    return TuneOptions(**{**base, **{k: v for k, v in given.items() if v is not None}})


def _check(args: argparse.Namespace, console: Any) -> int:
    """``harness tune --check DIR``: the tune's decisions on fresh paired seeds."""
    from harness.runs.sweep import default_workers
    from harness.tuning.check import DEFAULT_EPISODES, check_lines, run_check

    if args.files or args.analyse:
        raise HarnessError("--check DIR takes no task files and no --analyse")
    result = run_check(
        Path(args.check),
        seed=args.seed,
        episodes=args.episodes or DEFAULT_EPISODES,
        workers=args.workers or default_workers(),
        out=Path(args.out) if args.out else None,
        progress=True,
        only=args.unit,
    )
    if result.interrupted:
        console.print(
            styled(
                "[yellow]interrupted[/]: the check decides nothing; finished episodes are kept "
                "in {run_dir}: run the same command to continue",
                run_dir=result.run_dir,
            )
        )
        return 130
    check_lines(
        result.table,
        lambda line: console.print(line, highlight=False, markup=False, soft_wrap=True),
    )
    for label, path in (("check", result.csv), ("report", result.md), ("run", result.run_dir)):
        console.print(f"  {label:9s} {path}", soft_wrap=True, highlight=False)
    return 0


def main(args: argparse.Namespace) -> int:
    console = make_console()
    if args.check:
        return _check(args, console)
    if args.unit:
        raise HarnessError("--unit goes with --check DIR (the units a check tests)")
    write = Path(args.write) if args.write else None
    Budget.parse(args.budget)  # one line for a garbage, zero or negative --budget
    if args.analyse:
        result = analyse(Path(args.analyse), args.objective, write)
    elif not args.files:
        raise HarnessError("give task or sweep files, or --analyse DIR")
    else:
        options = _options(args)
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
            announce=lambda line: console.print(
                line, highlight=False, markup=False, soft_wrap=True
            ),
            asset_root=Path(args.asset_root) if args.asset_root else None,
            objects=parse_object_substitutions(args.object),
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
    for line in lines(result.decisions) + object_lines(result.objects):
        console.print(line, highlight=False, markup=False, soft_wrap=True)
    rows = [("tuned", result.tuned_yaml), ("report", result.tuned_md), ("run", result.run_dir)]
    page = result.run_dir / "screen" / "report.html"  # the tune's page, decisions first
    rows += [("page", page)] if page.is_file() else []
    rows += [("written", path) for path in result.written]
    for label, path in rows:
        console.print(f"  {label:9s} {path}", soft_wrap=True, highlight=False)
    if result.timing:
        console.print(result.timing, soft_wrap=True, highlight=False)
    return 130 if result.interrupted else 0
