"""``tune``: screen the grid, race the best on fresh seeds, decide, write ``<out>/tune/``.

``<out>/screen`` is the grid sweep (an ordinary run directory: resume, replay, compare, audit),
``<out>/confirm`` the race's run directory (fresh seeds, ``harness.tuning.race``),
``<out>/tune.json`` the tune's options, and ``<out>/tune/``: ``decisions.csv`` (one row per
robot, arm and object), ``race.csv`` (every racer), ``success_map.csv`` (the screening),
``heatmaps/``, ``tuned.yaml`` (the keys to merge per task file) and ``tuned.md``; the report of
``<out>/screen`` (``report.html``) is the tune's page, its decisions first. A tune run
again with the same ``--out`` reuses every stored episode; ``--analyse`` only reads them.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import cast

import pandas as pd
import yaml

from harness.config import TaskConfig
from harness.errors import HarnessError
from harness.report.build import build_report
from harness.report.finish import finish_run
from harness.report.frames import frame_of
from harness.report.tables import load_episodes
from harness.runs.expansion import load_sweep_tasks
from harness.runs.rundir import RunDir, claim_new_dir
from harness.runs.sweep import default_workers, run_sweep
from harness.tuning.analysis import challengers, settings_frame, success_map
from harness.tuning.blocks import filter_keys, task_decisions, tuned_markdown, tuned_yaml
from harness.tuning.decide import Racer, UnitRace
from harness.tuning.decisions import lines, object_name, race_rows, unit_row
from harness.tuning.grid import (
    APPROACH_KEY,
    FACING_KEY,
    current_setting,
    filter_key,
    load_inputs,
    objective_tasks,
    tune_sweep,
)
from harness.tuning.heatmaps import write_heatmaps
from harness.tuning.race import Budget, RaceLog, RaceRunner, Unit, run_race
from harness.tuning.write import write_copy
from harness.writes import check_outputs, write_file

SCREEN_DIR, CONFIRM_DIR, TUNE_DIR, OPTIONS_FILE = "screen", "confirm", "tune", "tune.json"
SCREEN_SWEEP = ".screen-sweep.yaml"  # the generated grid, until its run directory holds it
TUNE_OUTPUTS = ("success_map.csv", "decisions.csv", "race.csv", "tuned.yaml", "tuned.md")


@dataclass(frozen=True)
class TuneOptions:
    """How a tune decides (``docs/tune.md``): screening seeds, racers, race blocks, budget."""

    objective: str = "valid"
    screen_seeds: int = 10
    top: int = 3  # challengers raced against the current setting, per unit
    block: int = 20  # fresh seeds per race round
    max_seeds: int = 100  # fresh seeds per unit at most (max_seeds / block looks)
    budget: str | None = None  # "N" race episodes or "Ns" CPU seconds
    alpha: float = 0.05
    engine: str = "mujoco"  # the execution engine of every screening and race episode
    sources: dict[str, str] = field(default_factory=dict)  # task name -> its file


@dataclass(frozen=True)
class TuneResult:
    """Where a tune wrote its outputs and what it decided."""

    run_dir: Path
    interrupted: bool
    decisions: pd.DataFrame
    yaml_text: str = ""
    tuned_yaml: Path = Path()
    tuned_md: Path = Path()
    heatmaps: list[Path] = field(default_factory=list)
    written: list[Path] = field(default_factory=list)
    log: RaceLog = field(default_factory=RaceLog)


def tune(
    paths: list[Path],
    *,
    step: int = 5,
    bands: int = 3,
    out: Path | None = None,
    seed: int | None = None,
    options: TuneOptions = TuneOptions(),
    workers: int | None = None,
    backend: str = "process",
    progress: bool = False,
    write: Path | None = None,
) -> TuneResult:
    """Screen the grid of ``harness.tuning.grid`` over the tasks of ``paths``, race and decide."""
    tasks, axes, sweep_seed = load_inputs(paths)
    tasks = objective_tasks(tasks, options.objective)
    sweep = tune_sweep(
        tasks,
        axes,
        step=step,
        bands=bands,
        episodes=options.screen_seeds,
        seed=seed if seed is not None else (sweep_seed or 0),
    )
    out = out or claim_new_dir(RunDir.default_path(sweep.name))
    check_tune_dir(out)
    screen = out / SCREEN_DIR
    if (screen / "sweep.yaml").is_file():
        outcome = run_sweep(
            resume_dir=screen,
            workers=workers,
            backend=backend,
            progress="tune screen" if progress else False,
            engine=options.engine,
            max_points=None,
        )
    else:
        # The generated sweep lives in the tune directory while the screening starts (no temp
        # folder that a killed tune would leave in /tmp); the run keeps its own sweep.yaml.
        path = write_file(
            out / SCREEN_SWEEP,
            yaml.safe_dump(sweep.model_dump(mode="json"), sort_keys=False),
            root=out,
        )
        try:
            outcome = run_sweep(
                path,
                out=screen,
                workers=workers,
                backend=backend,
                progress="tune screen" if progress else False,
                engine=options.engine,
                max_points=None,  # the tune grid is generated and bounded by --step / --bands
            )
        finally:
            path.unlink(missing_ok=True)
    finish_run(outcome.run_dir, options.objective)
    sources = {t.name: str(Path(t.source).resolve()) for t in tasks if t.source}
    options = TuneOptions(**{**asdict(options), "sources": sources})
    write_file(out / OPTIONS_FILE, json.dumps(asdict(options), indent=2), root=out)
    if outcome.stats.interrupted:
        return TuneResult(out, True, pd.DataFrame())
    return decide(
        out,
        options,
        backend=backend,
        workers=workers,
        may_run=True,
        write=write,
        progress=progress,
    )


TUNE_FILES = (OPTIONS_FILE, SCREEN_SWEEP, *(f"{TUNE_DIR}/{name}" for name in TUNE_OUTPUTS))


def check_tune_dir(out: Path) -> None:
    """Refuse, before screening, a tune directory where a write would follow a planted link
    or hit a special file (``tune/``, ``tune/heatmaps/``, ``tune.json``, ``tuned.yaml``, ...)."""
    if out.exists():
        check_outputs(out, TUNE_FILES, (TUNE_DIR, f"{TUNE_DIR}/heatmaps"))


def analyse(out: Path, objective: str | None = None, write: Path | None = None) -> TuneResult:
    """Decide again from the stored episodes only (a missing race block: "undecided")."""
    path = out / OPTIONS_FILE
    if not path.is_file():
        raise HarnessError(f"{out}: not a tune directory (no {OPTIONS_FILE})")
    check_tune_dir(out)
    options = TuneOptions(**json.loads(path.read_text(encoding="utf-8")))
    if objective:
        options = TuneOptions(**{**asdict(options), "objective": objective})
    return decide(out, options, backend="serial", workers=1, may_run=False, write=write)


def _current(task: TaskConfig, axes: dict[str, list[object]]) -> tuple[str, str]:
    """The task's current setting as the JSON of the grid values that keep the same axes."""
    setting = current_setting(task)
    found = []
    for key in (APPROACH_KEY, FACING_KEY):
        match = [v for v in axes[key] if filter_key(v) == filter_key(setting[key])]  # type: ignore[arg-type]
        if not match:
            raise HarnessError(f"the current {key} of task {task.name!r} is not a grid value")
        found.append(json.dumps(match[0]))
    return found[0], found[1]


def _units(
    success: pd.DataFrame,
    tasks: dict[str, TaskConfig],
    axes: dict[str, list[object]],
    options: TuneOptions,
) -> tuple[list[Unit], dict[tuple[str, str], dict[str, str]]]:
    units, names = [], {}
    looks = max(1, options.max_seeds // options.block)
    for key, group in success.groupby(["task", "context"], sort=False):
        task, context = cast(tuple[str, str], key)
        current = _current(tasks[str(task)], axes)
        chosen = challengers(frame_of(group), current, options.top)
        racers = [Racer(current, 0), *(Racer(s, i + 1) for i, s in enumerate(chosen))]
        units.append(Unit(str(task), str(context), UnitRace(racers, looks, options.alpha)))
        first = group.iloc[0]
        names[(str(task), str(context))] = {
            "robot": str(first["robot"]),
            "arm": str(first["arm"]),
            "object": object_name(str(context), str(first["object"])),
        }
    return units, names


def decide(
    out: Path,
    options: TuneOptions,
    *,
    backend: str,
    workers: int | None,
    may_run: bool,
    write: Path | None,
    progress: bool = False,
) -> TuneResult:
    """Race the screening's best against the current setting per unit and write the outputs;
    ``progress`` shows each race round's episodes."""
    screen = RunDir(out / SCREEN_DIR)
    sweep = screen.load_sweep()
    tasks = {t.name: t for t in load_sweep_tasks(sweep, screen.sweep_yaml)}
    settings = settings_frame(load_episodes(screen.path), sweep, options.objective)
    success = success_map(settings)
    units, names = _units(success, tasks, sweep.axes, options)
    runner = RaceRunner(
        out / CONFIRM_DIR,
        sweep,
        list(tasks.values()),
        options.max_seeds,
        objective=options.objective,
        engine=options.engine,
        backend=backend,
        workers=workers or default_workers(),
        may_run=may_run,
        progress=progress,
    )
    log = run_race(units, runner, options.block, Budget.parse(options.budget))
    if may_run and log.episodes and not log.interrupted:
        finish_run(out / CONFIRM_DIR, options.objective)
    why = "budget spent" if log.budget_spent else ("interrupted" if log.interrupted else "")
    decisions = pd.DataFrame(
        [unit_row(u, _unit_map(success, u), names[(u.task, u.context)], why) for u in units]
    )
    folder = out / TUNE_DIR
    for name, table in (
        ("success_map.csv", success),
        ("decisions.csv", decisions),
        ("race.csv", race_rows(units)),
    ):
        write_file(folder / name, table.to_csv(index=False), root=out)
    images = write_heatmaps(success, decisions, folder / "heatmaps", options.objective, out)
    header = _header(out, sweep.seed, options, log)
    text = tuned_yaml(decisions, tasks, header, options.sources)
    write_file(folder / "tuned.yaml", text, root=out)
    link = f"../{SCREEN_DIR}/report.html"
    page = f"\nPage (decisions first, then the screening): [{link}]({link})\n"
    markdown = tuned_markdown(decisions, text, header, images) + page
    write_file(folder / "tuned.md", markdown, root=out)
    written = _write(decisions, tasks, options, write) if write else []
    if (screen.path / "report.html").is_file():  # the tune's page: its decisions first
        build_report(screen.path, objective=options.objective)
    return TuneResult(
        out,
        log.interrupted,
        decisions,
        text,
        folder / "tuned.yaml",
        folder / "tuned.md",
        list(images.values()),
        written,
        log,
    )


def _unit_map(success: pd.DataFrame, unit: Unit) -> pd.DataFrame:
    return frame_of(success[(success["task"] == unit.task) & (success["context"] == unit.context)])


def _header(out: Path, seed: int, options: TuneOptions, log: RaceLog) -> list[str]:
    return [
        f"harness tune {out}: objective {options.objective}; screening {options.screen_seeds} "
        f"seeds (sweep seed {seed}); race of the current + {options.top} best on fresh seeds "
        f"(sweep seed {seed + 100_000}), blocks of {options.block} up to {options.max_seeds}; "
        f"exact one-sided McNemar, Holm over the racers, alpha {options.alpha} split over "
        f"{max(1, options.max_seeds // options.block)} looks"
        + (
            "; the validity phase is not run under reference semantics (nothing this objective"
            " reads needs it: the rows' validity columns are empty, as with validity: off)."
            if options.objective == "reference"
            else "."
        ),
        f"race: {log.rounds} rounds, {log.episodes} episodes, {log.seconds:.0f} episode-seconds"
        + ("; budget spent" if log.budget_spent else "")
        + ("; interrupted (run the tune again with the same --out)" if log.interrupted else ""),
    ]


def _write(
    decisions: pd.DataFrame, tasks: dict[str, TaskConfig], options: TuneOptions, folder: Path
) -> list[Path]:
    """Per task with a file: the merged copy and its diff under ``folder``."""
    written: list[Path] = []
    for name, decided, _ in task_decisions(decisions):
        source = options.sources.get(name)
        if source is None or not Path(source).is_file():
            continue  # an inline or InternDataEngine task: no task file of ours to copy
        keys = filter_keys(tasks[name], decided["setting"])
        written.extend(write_copy(Path(source), keys, folder))
    return written


__all__ = ["TuneOptions", "TuneResult", "analyse", "lines", "tune"]
