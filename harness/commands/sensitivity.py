"""``harness sensitivity``: one sweep per chosen value, then one table of what moves.

The plan is ``harness.runs.sensitivity``; the table ``harness.report.sensitivity_values``.
Each sweep runs in ``OUT/<name>/`` (its ``sweep.yaml`` beside it as ``OUT/<name>.yaml``); a
rerun resumes the sweeps that are there, so an interrupted plan loses nothing. The table is
written to ``OUT/sensitivity.md`` with the uncovered values (those the plan cannot sweep)
counted under it.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import yaml

from harness.commands.console import make_console
from harness.files import safe_file_name


def main(args: argparse.Namespace) -> int:
    from harness.runs.sensitivity import baseline_name, baselines, default_examples, plan, sweep_of

    console = make_console()
    examples = Path(args.examples) if args.examples else default_examples()
    handover = Path(args.handover) if args.handover else None
    objects = dict(item.split("=", 1) for item in args.handover_object or [])
    values, uncovered = plan(args.robots, examples, handover, objects)
    if args.only:
        values = [v for v in values if v.key in args.only]
    bases = baselines(values)
    out = Path(args.out)
    sweeps: list[dict[str, Any]] = [
        sweep_of(v, args.episodes, args.seed, baseline=True) for v in bases.values()
    ]
    sweeps += [sweep_of(v, args.episodes, args.seed) for v in values]
    total = 0
    for sweep in sweeps:
        size = _episodes(sweep)
        total += size
        console.print(f"  {sweep['name']}: {size} episodes")
    console.print(
        f"{len(values)} chosen value(s), {len(sweeps)} sweep(s), {total} episodes at "
        f"{args.episodes} seeds per point; uncovered: {len(uncovered)}"
    )
    for line in uncovered:
        console.print(f"  uncovered: {line}")
    if args.plan:
        return 0
    from harness.runs.sweep import run_sweep
    from harness.writes import write_file

    for sweep in sweeps:
        path = out / safe_file_name(str(sweep["name"]), ".yaml")
        run_dir = out / safe_file_name(str(sweep["name"]))
        resume = run_dir if (run_dir / "sweep.yaml").is_file() else None
        if resume is None:  # a resumed run keeps its own sweep (its size too)
            write_file(path, yaml.safe_dump(sweep, sort_keys=False))
        console.print(f"sweep {sweep['name']} ({'resuming' if resume else 'new'})")
        outcome = run_sweep(
            None if resume else path,
            resume_dir=resume,
            out=None if resume else run_dir,
            workers=args.workers,
            progress=False,
        )
        if outcome.stats.interrupted:
            console.print("interrupted: rerun the same command to continue")
            return 130
    text = report(out, values, {baseline_name(v) for v in values}, uncovered, args.episodes)
    write_file(out / "sensitivity.md", text)
    console.print(text)
    return 0


def _episodes(sweep: dict[str, Any]) -> int:
    points = 1
    for values in sweep["axes"].values():
        points *= len(values)
    return points * len(sweep["tasks"]) * int(sweep["episodes_per_point"])


def report(
    out: Path, values: list[Any], _baselines: set[str], uncovered: list[str], episodes: int
) -> str:
    """The markdown of the table over the finished runs in ``out``."""
    from harness.markdown import markdown_table, markdown_text
    from harness.report.sensitivity_values import sensitivity_table, value_rows
    from harness.runs.sensitivity import baseline_name
    from harness.runs.store import read_episodes_csv

    rows: list[list[str]] = []
    missing: list[str] = []
    for value in values:
        swept_csv = out / value.name / "episodes.csv"
        base_csv = out / baseline_name(value) / "episodes.csv"
        if not swept_csv.is_file() or not base_csv.is_file():
            missing.append(value.name)
            continue
        label = f"{value.robot or 'task'}: {value.key} = {_text(value.default)} ({value.label})"
        rows += value_rows(
            label,
            value.key,
            value.default,
            value.values,
            read_episodes_csv(swept_csv),
            read_episodes_csv(base_csv),
        )
    table = sensitivity_table(rows, episodes)
    lines = [f"## {table.title}", "", *markdown_table(table.header, table.rows), ""]
    lines += [markdown_text(table.note), ""]
    lines.append(
        f"Chosen values: {len(values)} swept, {len(missing)} not yet run"
        f"{' (' + ', '.join(missing) + ')' if missing else ''}, {len(uncovered)} uncovered"
        f"{': ' + '; '.join(uncovered) if uncovered else ''}."
    )
    return "\n".join(lines) + "\n"


def _text(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, dict):
        return "robot.yaml placement"
    return str(value)
