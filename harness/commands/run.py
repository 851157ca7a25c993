"""``harness run TASK.yaml``: run episodes of one task, live, into a run directory.

The run is written exactly like a one-point sweep (``sweep.yaml``, ``episodes.csv``, parquet,
summary and report), so every report tool works on it and ``harness sweep --resume RUN_DIR``
can continue it. ``--set key=value`` overrides become the point's parameters (``param.<key>``
columns). Episode seeds and ids are those a sweep with the same seed would use.

``--interndata FILE`` runs every pick skill of an InternDataEngine task file (each as its own
task), with ``--asset-root`` and ``--object NAME=PATH[@SCALE]`` substitutions. The skills it
does not run (place, heuristic__skill, ...) are listed before the run and, with every other
note of the mapping (ignored keys, approximations), in ``RUN_DIR/skipped.txt``.
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rich.live import Live
from rich.table import Table
from rich.text import Text

from harness.commands.console import make_console, say, styled
from harness.commands.validate import print_warnings
from harness.config import (
    ConfigError,
    SweepConfig,
    TaskConfig,
    apply_overrides,
    load_task,
    parse_set_value,
    warning_lines,
)
from harness.errors import HarnessError
from harness.failures import UNRATED_REASONS

if TYPE_CHECKING:
    from harness.interndata import InternDataPick

LIVE_ROWS = 25  # episodes shown in the live table (the latest ones)


def parse_overrides(items: list[str]) -> dict[str, Any]:
    """``["pick.test_mode=forward", ...]`` -> ``{"pick.test_mode": "forward"}`` (YAML values)."""
    out: dict[str, Any] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ConfigError(f"--set expects KEY=VALUE, got {item!r}")
        try:
            out[key.strip()] = parse_set_value(value)
        except ValueError as exc:
            raise ConfigError(f"--set {key.strip()}: {exc}") from None
    return out


def load_interndata_picks(args: argparse.Namespace) -> list[InternDataPick]:
    """``--interndata FILE``: every pick of the file, with its assets and grasp files checked."""
    if args.task:
        raise HarnessError("give either TASK.yaml or --interndata FILE, not both")
    from harness.interndata import load_interndata_tasks, parse_object_substitutions

    picks = load_interndata_tasks(
        args.interndata,
        asset_root=Path(args.asset_root) if args.asset_root else None,
        objects=parse_object_substitutions(args.object),
        check_grasps=True,
    )
    if not picks:
        raise HarnessError(f"{args.interndata}: the file has no pick skill")
    return picks


def load_run_tasks(args: argparse.Namespace) -> list[TaskConfig]:
    """The task(s) of this run, with paths made absolute."""
    from harness.runs.expansion import absolute_paths

    if args.interndata:
        return [absolute_paths(pick.task) for pick in load_interndata_picks(args)]
    if not args.task:
        raise HarnessError("give a task YAML (harness run TASK.yaml) or --interndata FILE")
    if args.object:
        raise HarnessError("--object substitutes InternDataEngine assets; use it with --interndata")
    if args.asset_root:
        raise HarnessError(
            "--asset-root resolves InternDataEngine asset paths; use it with --interndata"
        )
    return [absolute_paths(load_task(args.task))]


def run_name(tasks: list[TaskConfig]) -> str:
    name = tasks[0].name if len(tasks) == 1 else f"{tasks[0].name}+{len(tasks) - 1}"
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name) or "run"


def _table(rows: list[dict[str, Any]], total: int) -> Table:
    table = Table(title=f"episodes {len(rows)}/{total}", expand=False)
    for column in ("#", "task", "seed", "result", "reason", "lift mm", "forces N", "wall s"):
        table.add_column(column, justify="right" if column not in ("task", "reason") else "left")
    for row in rows[-LIVE_ROWS:]:
        ok = bool(row.get("success"))
        lift = row.get("lift_height_m")
        left, right = row.get("finger_force_left_n"), row.get("finger_force_right_n")
        table.add_row(
            str(row.get("episode_index", "")),
            str(row.get("task", "")),
            str(row.get("seed", "")),  # in full: a cut seed reproduces nothing
            Text("success", style="green") if ok else Text("fail", style="red"),
            str(row.get("failure_reason", "")),
            _fmt(lift, 1e3, "{:.0f}"),
            f"{_fmt(left, 1, '{:.1f}')}/{_fmt(right, 1, '{:.1f}')}",
            _fmt(row.get("wall_time_s"), 1, "{:.2f}"),
        )
    return table


def _fmt(value: Any, scale: float, pattern: str) -> str:
    try:
        number = float(value) * scale
    except (TypeError, ValueError):
        return ""
    return "" if number != number else pattern.format(number)


def main(args: argparse.Namespace) -> int:
    from harness.runs.expansion import absolute_paths, expand
    from harness.runs.progress import ProgressLines
    from harness.runs.rundir import RunDir

    if args.episodes < 1:
        raise HarnessError(f"--episodes must be >= 1, got {args.episodes}")
    console = make_console()
    picks = load_interndata_picks(args) if args.interndata else []
    tasks = [absolute_paths(pick.task) for pick in picks] if picks else load_run_tasks(args)
    overrides = parse_overrides(args.overrides)
    for task in tasks:  # fail early, with the task file named, on a bad override
        configured = apply_overrides(task, overrides)
        set_physics = any(key.startswith("physics.") for key in overrides)
        print_warnings(warning_lines(configured, context="--set" if set_physics else ""))
    sweep = SweepConfig(
        name=run_name(tasks),
        tasks=[task.model_dump(mode="json") for task in tasks],
        axes={key: [value] for key, value in overrides.items()},
        episodes_per_point=args.episodes,
        seed=args.seed,
        record=args.record,
    )
    episodes = expand(sweep, None)
    from harness.files import recording_reads
    from harness.runs.preflight import check_tasks

    with recording_reads() as inputs:  # the files the tasks load, hashed for --resume
        check_tasks([episode.task for episode in episodes[:: sweep.episodes_per_point]])
    run = RunDir(Path(args.out)) if args.out else RunDir.default(sweep.name)
    run.create(
        sweep,
        tasks,
        taken="run directory already holds a run; choose another --out",
        inputs=inputs,
    )
    if picks:
        _print_interndata(console, args.interndata, picks, run)
    rows: list[dict[str, Any]] = []
    start = time.perf_counter()
    # Without a terminal the live table shows only at the end: plain lines meanwhile.
    lines = None if console.is_terminal else ProgressLines("run", len(episodes)).start()
    workers = getattr(args, "workers", 1) or 1
    try:
        with Live(_table(rows, len(episodes)), console=console, refresh_per_second=8) as live:

            def on_result(row: dict[str, Any]) -> None:
                run.append(row)
                rows.append(row)
                live.update(_table(rows, len(episodes)))
                if lines is not None:
                    successes = sum(bool(r.get("success")) for r in rows)
                    lines.advance(note=f"success {successes}/{len(rows)}")

            _execute_all(episodes, run.path, sweep.record, workers, on_result)
    except KeyboardInterrupt:
        from harness.runs.rundir import interrupted_line

        console.print(interrupted_line(), markup=False, highlight=False, soft_wrap=True)
    console.print()  # ends the live table's last line
    if lines is not None:
        lines.stop()  # its last line: how long the run took
    run.finalize()
    from harness.report.finish import finish_run  # scipy, matplotlib: only after the run

    finish_run(run.path)
    wall_s = time.perf_counter() - start
    for task in tasks:
        console.print(
            filters_line(apply_overrides(task, overrides)),
            soft_wrap=True,
            highlight=False,
            markup=False,
        )
    return _print_outcome(console, rows, len(episodes), run.path, wall_s, bool(picks))


def filters_line(task: TaskConfig) -> str:
    """``filters fr3 left (fr3_pick): filter_x_dir forward 90, filter_z_dir downward 140``:
    the filters the run ran, on the robot's own axes (what ``harness compare`` matches)."""
    from harness.grasps import resolve_filters
    from harness.robots.facts import reference_convention

    resolved = resolve_filters(task.pick, reference_convention(task.robot))
    parts = [
        f"{key} {spec.direction} {'-'.join(f'{a:g}' for a in spec.angles)}"
        for key, spec in sorted(resolved.items())
    ]
    if task.pick.direction_to_obj:
        parts.append(f"direction_to_obj {task.pick.direction_to_obj}")
    return f"filters {task.robot} {task.arm} ({task.name}): {', '.join(parts) or 'none'}"


def _print_outcome(
    console: Any,
    rows: list[dict[str, Any]],
    planned: int,
    run_dir: Path,
    wall_s: float,
    interndata: bool,
) -> int:
    """The run's rate line (``error`` rows excluded), failures, fallback, where things are; the
    exit code: 130 when interrupted, 1 when ``error`` rows exceed ``MAX_ERROR_SHARE``, else 0."""
    from harness.runs.limits import error_rows_line, too_many_errors

    errors = sum(row.get("failure_reason") == "error" for row in rows)
    console.print(f"{rate_line(rows)} in {wall_s:.1f} s")
    failures: dict[str, int] = {}
    for row in rows:
        if not row.get("success"):
            reason = str(row.get("failure_reason") or "unknown")
            failures[reason] = failures.get(reason, 0) + 1
    if failures:
        console.print(
            "failures: " + ", ".join(f"{k} {v}" for k, v in sorted(failures.items(), key=_count))
        )
    fallback = sum(row.get("filter_outcome") == "fallback" for row in rows)
    if fallback:
        console.print(
            styled(
                "[yellow]reference fallback[/] in {fallback} episode(s): the filter kept no "
                "candidate and poses 0..19 of the unfiltered file were tried instead",
                fallback=fallback,
            ),
            soft_wrap=True,
        )
    extra = ", skipped.txt" if interndata else ""
    console.print(f"run directory: {run_dir}  (episodes.csv, summary.csv, report{extra})")
    if (line := error_rows_line(errors, len(rows), run_dir)) is not None:
        say(f"error: {line}" if too_many_errors(errors, len(rows)) else line, file=sys.stderr)
    if len(rows) != planned:
        return 130
    return 1 if too_many_errors(errors, len(rows)) else 0


def _print_interndata(console: Any, source: str, picks: list[Any], run: Any) -> None:
    """What an InternData task file became: one line per pick, and the notes file's path."""
    from harness.interndata import note_lines, summary_lines

    for line in summary_lines(source, picks):
        console.print(line, highlight=False, markup=False, soft_wrap=True)
    notes = run.write_notes(note_lines(source, picks))
    console.print(
        f"notes (skipped skills, ignored keys, approximations): {notes}",
        highlight=False,
        markup=False,
        soft_wrap=True,
    )


def _execute_all(
    episodes: list[Any],
    run_dir: Path,
    record: str,
    workers: int,
    on_result: Callable[[dict[str, Any]], None],
) -> None:
    """Run ``episodes`` in this process, or on a pool of ``workers`` processes as ``harness
    sweep --workers`` does (rows as they finish); an interrupted pool raises KeyboardInterrupt."""
    if workers <= 1:
        from harness.runs.worker import execute

        for episode in episodes:
            on_result(execute(episode, str(run_dir), record))
        return
    from harness.runs.executors import executor_for

    stats = executor_for("process", workers)(episodes, run_dir, record, on_result)
    if stats.interrupted:
        raise KeyboardInterrupt


def rate_line(rows: list[dict[str, Any]]) -> str:
    """``success k/n = r% (95% Wilson ...); valid v/m = ...``: error rows are in neither rate."""
    from harness.report.stats import wilson_interval  # scipy: imported only when there is a result

    rated = [row for row in rows if row.get("failure_reason") not in UNRATED_REASONS]
    parts = []
    judged = [row for row in rated if row.get("valid") or row.get("invalid_reason")]
    for name, hits, n in (
        ("success", sum(bool(row.get("success")) for row in rated), len(rated)),
        ("valid", sum(bool(row.get("valid")) for row in judged), len(judged)),
    ):
        if n or name == "success":
            lo, hi = wilson_interval(hits, n)
            rate = f"{hits / n:.0%}" if n else "-"
            parts.append(f"{name} {hits}/{n} = {rate} (95% Wilson interval {lo:.2f}-{hi:.2f})")
    errors = len(rows) - len(rated)
    return "; ".join(parts) + (f"; {errors} error row(s) in no rate" if errors else "")


def _count(item: tuple[str, int]) -> tuple[int, str]:
    return (-item[1], item[0])
