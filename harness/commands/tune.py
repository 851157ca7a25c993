"""``harness tune TASK_OR_SWEEP...``: run the tune grid, print the tuned blocks and the paths."""

from __future__ import annotations

import argparse
from pathlib import Path

from harness.commands.console import make_console
from harness.errors import HarnessError
from harness.tuning.run import analyse, tune


def main(args: argparse.Namespace) -> int:
    console = make_console()
    if args.analyse:
        result = analyse(Path(args.analyse), args.objective)
    elif not args.files:
        raise HarnessError("give task or sweep files, or --analyse RUN_DIR")
    else:
        result = tune(
            [Path(f) for f in args.files],
            episodes=args.episodes,
            step=args.step,
            bands=args.bands,
            objective=args.objective,
            out=Path(args.out) if args.out else None,
            workers=args.workers,
            seed=args.seed,
            progress=True,
            engine=args.engine,
        )
    if result.interrupted:
        console.print(
            f"[yellow]interrupted[/]: finished episodes are kept; continue with harness sweep "
            f"--resume {result.run_dir}, then harness tune --analyse {result.run_dir}"
        )
        return 130
    console.print(result.yaml_text, highlight=False, markup=False, soft_wrap=True)
    for label, path in (
        ("tuned", result.tuned_yaml),
        ("report", result.tuned_md),
        ("heatmaps", result.tuned_md.parent / "heatmaps"),
        ("run", result.run_dir),
    ):
        console.print(f"  {label:9s} {path}", soft_wrap=True, highlight=False)
    return 0
