"""``tune``: screen the grid, race the best on fresh seeds, decide, write ``<out>/tune/``.

``<out>/screen`` is the screening sweep (an ordinary run directory: resume, replay, compare,
audit): the coarse pass over every direction, followed by ``<out>/refine``, the fine grid about
the best directions (or, with ``coarse`` off, the fine grid alone); ``<out>/confirm`` the race's
run directory (fresh seeds, ``harness.tuning.race``), ``<out>/tune.json`` the tune's options
with each unit's race plan and racers (a rerun continues that race), and ``<out>/tune/``:
``decisions.csv`` (one row per robot, arm and object), ``race.csv`` (every racer),
``success_map.csv`` (the screening), ``heatmaps/``, ``tuned.yaml`` (the keys to merge per task
file) and ``tuned.md``. A tune run again with the same ``--out`` reuses every stored episode;
``--analyse`` only reads them. The report of ``<out>/screen`` (``report.html``) is the
tune's page, its decisions first.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any, cast

import pandas as pd
import yaml

from harness.config import SweepConfig, TaskConfig
from harness.errors import HarnessError
from harness.report.build import build_report
from harness.report.finish import finish_run
from harness.report.frames import column, frame_of
from harness.report.tables import load_episodes
from harness.runs.rundir import RunDir, claim_new_dir
from harness.runs.sweep import default_workers, run_sweep
from harness.tuning.analysis import challengers, ranked, settings_frame, success_map
from harness.tuning.decide import Racer, UnitRace
from harness.tuning.decisions import lines, object_name, race_rows, unit_row
from harness.tuning.exceptions import (
    EXCEPTIONS_DIR,
    exception_tests,
    objects_table,
    run_exceptions,
)
from harness.tuning.grid import (
    APPROACH_KEY,
    FACING_KEY,
    current_setting,
    direction_of,
    filter_key,
    load_inputs,
    objective_tasks,
    tune_sweep,
)
from harness.tuning.heatmaps import write_heatmaps
from harness.tuning.options import (
    OPTIONS_FILE,
    RACE_KEYS,
    TuneOptions,
    check_continuation,
    stored_options,
)
from harness.tuning.outputs import header_lines, write_copies, write_tuned
from harness.tuning.phase_clock import PhaseClock
from harness.tuning.planning import make_plan, plan_lines, plan_of, screening_discordance, unit_key
from harness.tuning.race import Budget, RaceLog, RaceRunner, Unit, run_race
from harness.tuning.screening import load_screening
from harness.tuning.template_units import (
    Member,
    pooled_map,
    template_groups,
    template_plan,
    with_template_maps,
)
from harness.writes import check_outputs, write_file

SCREEN_DIR, CONFIRM_DIR, TUNE_DIR = "screen", "confirm", "tune"
DEFAULT_OPTIONS = TuneOptions()
REFINE_DIR = "refine"  # the fine pass about the coarse pass's best directions
# Each pass's generated sweep, in the tune directory until its run directory holds it.
PASS_SWEEPS = {SCREEN_DIR: ".screen-sweep.yaml", REFINE_DIR: ".refine-sweep.yaml"}
TUNE_OUTPUTS = (
    "success_map.csv",
    "decisions.csv",
    "race.csv",
    "objects.csv",
    "tuned.yaml",
    "tuned.md",
)


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
    timing: str = ""  # where the tune's wall time went (``PhaseClock.line``; a tune that ran)
    objects: pd.DataFrame = field(default_factory=pd.DataFrame)  # template groups' objects


def tune(
    paths: list[Path],
    *,
    step: int = 5,
    bands: int = 3,
    out: Path | None = None,
    seed: int | None = None,
    options: TuneOptions = DEFAULT_OPTIONS,
    workers: int | None = None,
    backend: str = "process",
    progress: bool = False,
    write: Path | None = None,
    announce: Callable[[str], None] | None = None,
    asset_root: Path | None = None,
    objects: dict[str, str] | None = None,
) -> TuneResult:
    """Screen the grid of ``harness.tuning.grid`` over the tasks of ``paths``, race and decide.

    On an ``out`` that holds a started race (``tune.json`` with plans) the tune continues that
    race: the same sequential test, its looks replayed from the stored rows at the same levels;
    options that would change the test (``RACE_KEYS``) must equal the stored ones."""
    inputs = load_inputs(paths, asset_root, objects)
    tasks, axes, sweep_seed = inputs.tasks, inputs.axes, inputs.seed
    tasks = objective_tasks(tasks, options.objective)
    if announce:
        for line in inputs.group_lines:
            announce(line)
    options = replace(options, groups=inputs.groups, pick_paths=inputs.pick_paths)
    grid = {
        "step": step,
        "bands": bands,
        "episodes": options.screen_seeds,
        "seed": seed if seed is not None else (sweep_seed or 0),
    }
    first = tune_sweep(tasks, axes, **grid, coarse=options.coarse)  # type: ignore[arg-type]
    out = out or claim_new_dir(RunDir.default_path(first.name))
    check_tune_dir(out)
    stored = stored_options(out)
    if stored is not None and stored.plans:
        check_continuation(out, stored, options)
        options = TuneOptions(**{**asdict(options), "plans": stored.plans})
    run = {"workers": workers, "backend": backend, "progress": progress}
    started, clock = time.perf_counter(), PhaseClock()
    outcome = _screen(first, out, SCREEN_DIR, run, options.objective, clock)
    ran, interrupted = outcome.stats.finished, outcome.stats.interrupted
    if options.coarse and not interrupted:
        directions = best_directions(out / SCREEN_DIR, first, tasks, options.objective)
        if announce:
            announce(
                f"coarse pass over every direction: refining approach {directions[0]} x facing "
                f"{directions[1]}"
            )
        second = tune_sweep(tasks, axes, **grid, directions=directions, name="tune-refine")  # type: ignore[arg-type]
        outcome = _screen(second, out, REFINE_DIR, run, options.objective, clock)
        ran, interrupted = ran + outcome.stats.finished, outcome.stats.interrupted
    elapsed = time.perf_counter() - started
    sources = {t.name: str(Path(t.source).resolve()) for t in tasks if t.source}
    seconds_each = elapsed / ran if ran else (stored.seconds_each if stored else 0.0)
    options = TuneOptions(**{**asdict(options), "sources": sources, "seconds_each": seconds_each})
    write_file(out / OPTIONS_FILE, json.dumps(asdict(options), indent=2), root=out)
    if interrupted:
        return TuneResult(out, True, pd.DataFrame())
    result = decide(
        out,
        options,
        backend=backend,
        workers=workers,
        may_run=True,
        write=write,
        announce=announce,
        progress=progress,
    )
    clock.lap("race and outputs")  # the race rounds, their report, heatmaps, tuned.md
    return replace(result, timing=clock.line())


TUNE_FILES = (
    OPTIONS_FILE,
    *PASS_SWEEPS.values(),
    *(f"{TUNE_DIR}/{name}" for name in TUNE_OUTPUTS),
)


def check_tune_dir(out: Path) -> None:
    """Refuse, before screening, a tune directory where a write would follow a planted link
    or hit a special file (``tune/``, ``tune/heatmaps/``, ``tune.json``, ``tuned.yaml``, ...)."""
    if out.exists():
        check_outputs(out, TUNE_FILES, (TUNE_DIR, f"{TUNE_DIR}/heatmaps"))


def _screen(
    sweep: SweepConfig, out: Path, name: str, run: dict[str, Any], objective: str, clock: PhaseClock
) -> Any:
    """Run (or resume) the screening pass ``out/name`` and build its report (each a lap of
    ``clock``). The generated sweep lives in the tune directory while the pass starts (no temp
    folder that a killed tune would leave in /tmp); the run keeps its own sweep.yaml."""
    folder = out / name
    label = f"tune {name}" if run["progress"] else False
    if (folder / "sweep.yaml").is_file():
        outcome = run_sweep(resume_dir=folder, max_points=None, **{**run, "progress": label})
    else:
        path = write_file(
            out / PASS_SWEEPS[name],
            yaml.safe_dump(sweep.model_dump(mode="json"), sort_keys=False),
            root=out,
        )
        try:  # the tune grid is generated and bounded by --step / --bands: no max_points
            outcome = run_sweep(path, out=folder, max_points=None, **{**run, "progress": label})
        finally:
            path.unlink(missing_ok=True)
    clock.lap(name)
    finish_run(outcome.run_dir, objective)
    clock.lap(f"{name} report")
    return outcome


def best_directions(
    folder: Path, sweep: SweepConfig, tasks: list[TaskConfig], objective: str
) -> tuple[str, str]:
    """The (approach, facing) directions the refine pass searches: per axis, the direction of
    most units' best coarse setting (ties, and an axis whose best is no filter: the current
    setting's direction, else downward / forward)."""
    success = success_map(settings_frame(load_episodes(folder), sweep, objective))
    votes: list[dict[str, float]] = [{}, {}]
    defaults = ["downward", "forward"]
    by_name = {t.name: t for t in tasks}
    for key, group in success.groupby(["task", "context"], sort=False):
        task = by_name[str(cast(tuple[str, str], key)[0])]
        current = _current(task, sweep.axes)
        best = ranked(frame_of(group), current).iloc[0]
        for axis, text in enumerate((str(best["approach"]), str(best["facing"]))):
            now = direction_of(current[axis]) or defaults[axis]
            chosen = direction_of(text) or now
            votes[axis][chosen] = votes[axis].get(chosen, 0.0) + 1.0
            votes[axis][now] = votes[axis].get(now, 0.0) + 0.5  # ties go to the current's
    return (
        max(votes[0], key=votes[0].__getitem__) if votes[0] else defaults[0],
        max(votes[1], key=votes[1].__getitem__) if votes[1] else defaults[1],
    )


def analyse(out: Path, objective: str | None = None, write: Path | None = None) -> TuneResult:
    """Decide again from the stored episodes only (a missing race block: "undecided")."""
    path = out / OPTIONS_FILE
    if not path.is_file():
        raise HarnessError(f"{out}: not a tune directory (no {OPTIONS_FILE})")
    check_tune_dir(out)
    options = TuneOptions.load(path)
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
    settings: pd.DataFrame,
    tasks: dict[str, TaskConfig],
    axes: dict[str, list[object]],
    options: TuneOptions,
) -> tuple[list[Unit], dict[tuple[str, str], dict[str, str]], dict[str, dict[str, Any]]]:
    units, names, plans = [], {}, {}
    templates = template_groups(success, options)
    grouped = {m for members in templates.values() for m in members}
    for key, group in success.groupby(["task", "context"], sort=False):
        task, context = cast(tuple[str, str], key)
        if (str(task), str(context)) in grouped:
            continue  # raced with its template group (below)
        current = _current(tasks[str(task)], axes)
        name = unit_key(str(task), str(context))
        stored = options.plans.get(name, {}).get("challengers")
        if isinstance(stored, list):  # a continued race keeps its racers
            chosen = [(str(a), str(f)) for a, f in stored]
        else:
            chosen = challengers(frame_of(group), current, options.top)
        racers = [Racer(current, 0), *(Racer(s, i + 1) for i, s in enumerate(chosen))]
        at = frame_of(group[(group["approach"] == current[0]) & (group["facing"] == current[1])])
        rate = float(column(at, "rate").iloc[0]) if len(at) else 0.5
        if name in options.plans:
            plan = plan_of(options.plans[name], options, len(chosen))
        else:
            psi = screening_discordance(settings, (str(task), str(context)), current, chosen)
            plan = make_plan(rate, psi, options, len(chosen))
        plans[name] = {
            "seeds": plan.seeds,
            "block": plan.block,
            "discordance": plan.discordance,
            "rate": rate,
            "challengers": [list(c) for c in chosen],
        }
        units.append(Unit(str(task), str(context), UnitRace(racers, plan)))
        first = group.iloc[0]
        names[(str(task), str(context))] = {
            "robot": str(first["robot"]),
            "arm": str(first["arm"]),
            "object": object_name(str(context), str(first["object"])),
        }
    for (name, context), members in templates.items():
        unit, label, plan = _template_unit(
            name, context, members, success, settings, tasks, axes, options
        )
        units.append(unit)
        names[(name, context)] = label
        plans[unit_key(name, context)] = plan
    return units, names, plans


def _template_unit(
    name: str,
    context: str,
    members: list[Member],
    success: pd.DataFrame,
    settings: pd.DataFrame,
    tasks: dict[str, TaskConfig],
    axes: dict[str, list[object]],
    options: TuneOptions,
) -> tuple[Unit, dict[str, str], dict[str, Any]]:
    """A template group's race unit (``harness.tuning.template_units``): its challengers are
    the best settings of the objects' mean screening rate."""
    current = _current(tasks[members[0][0]], axes)
    key = unit_key(name, context)
    pooled = pooled_map(success, members)
    stored = options.plans.get(key, {}).get("challengers")
    if isinstance(stored, list):
        chosen = [(str(a), str(f)) for a, f in stored]
    else:
        chosen = challengers(pooled, current, options.top)
    if key in options.plans:
        plan_data = {**options.plans[key]}
    else:
        plan_data = template_plan(success, settings, members, current, chosen, options)
    plan = plan_of(plan_data, options, len(chosen))
    racers = [Racer(current, 0), *(Racer(s, i + 1) for i, s in enumerate(chosen))]
    unit = Unit(name, context, UnitRace(racers, plan), members=tuple(members))
    first = tasks[members[0][0]]
    label = {
        "robot": first.robot,
        "arm": first.arm or "",
        "object": f"template over {len(members)} objects",
    }
    return unit, label, plan_data


def _objects(
    out: Path, sweep: Any, tasks: dict[str, TaskConfig], units: list[Unit],
    decisions: pd.DataFrame, success: pd.DataFrame, log: RaceLog, why: str,
    options: TuneOptions, backend: str, workers: int | None, may_run: bool, progress: bool,
    announce: Callable[[str], None] | None,
) -> tuple[pd.DataFrame, RaceLog]:  # fmt: skip
    """The template groups' exception tests and their objects table."""
    tests = exception_tests(units, decisions, success, log, why)
    exception_log = run_exceptions(
        out,
        sweep,
        list(tasks.values()),
        tests,
        options,
        backend=backend,
        workers=workers or default_workers(),
        may_run=may_run,
        progress=progress,
        announce=announce,
    )
    labels = {name: _object_label(task) for name, task in tasks.items()}
    objects = objects_table(units, decisions, success, tests, labels, options.objective)
    if may_run and exception_log.episodes and not exception_log.interrupted:
        finish_run(out / EXCEPTIONS_DIR, options.objective)
    return objects, exception_log


def decide(
    out: Path,
    options: TuneOptions,
    *,
    backend: str,
    workers: int | None,
    may_run: bool,
    write: Path | None,
    progress: bool = False,
    announce: Callable[[str], None] | None = None,
) -> TuneResult:
    """Race the screening's best against the current setting per unit and write the outputs;
    ``progress`` shows each race round's episodes."""
    screen = RunDir(out / SCREEN_DIR)
    sweep, tasks, settings = load_screening(out, options.objective)
    success = success_map(settings)
    units, names, plans = _units(success, settings, tasks, sweep.axes, options)
    success = with_template_maps(success, units, names)
    if may_run:
        options = TuneOptions(**{**asdict(options), "plans": plans})
        write_file(out / OPTIONS_FILE, json.dumps(asdict(options), indent=2), root=out)
    if announce is not None:
        for line in plan_lines(units, names, options):
            announce(line)
    runner = RaceRunner(
        out / CONFIRM_DIR,
        sweep,
        list(tasks.values()),
        max(u.race.plan.seeds for u in units),
        objective=options.objective,
        backend=backend,
        workers=workers or default_workers(),
        may_run=may_run,
        progress=progress,
        seconds_each=options.seconds_each,
        announce=announce,
    )
    log = run_race(units, runner, Budget.parse(options.budget))
    if may_run and log.episodes and not log.interrupted:
        finish_run(out / CONFIRM_DIR, options.objective)
    why = _cut_short(log, options)
    decisions = pd.DataFrame(
        [
            unit_row(u, _unit_map(success, u), names[(u.task, u.context)], why, options.objective)
            for u in units
        ]
    )
    objects, exception_log = _objects(
        out, sweep, tasks, units, decisions, success, log, why, options, backend, workers,
        may_run, progress, announce,
    )  # fmt: skip
    folder = out / TUNE_DIR
    for name, table in (
        ("success_map.csv", success),
        ("decisions.csv", decisions),
        ("race.csv", race_rows(units)),
        ("objects.csv", objects),
    ):
        write_file(folder / name, table.to_csv(index=False), root=out)
    images = write_heatmaps(success, decisions, folder / "heatmaps", options.objective, out)
    header = header_lines(out, sweep.seed, options, log)
    text = write_tuned(out, decisions, tasks, header, images, options, objects)
    written = write_copies(decisions, tasks, options, write, objects) if write else []
    if (screen.path / "report.html").is_file():  # the tune's page: its decisions first
        build_report(screen.path, objective=options.objective)
    return TuneResult(
        out,
        log.interrupted or exception_log.interrupted,
        decisions,
        text,
        folder / "tuned.yaml",
        folder / "tuned.md",
        list(images.values()),
        written,
        log,
        objects=objects,
    )


def _object_label(task: TaskConfig) -> str:
    """An object's name in the tables: its task's (a reference file's stem: one per object)."""
    return task.name


def _cut_short(log: RaceLog, options: TuneOptions) -> str:
    """Why the race ended before its own rule decided ('' when it did not): the reason an
    undecided verdict gives."""
    if log.budget_spent:
        return f"budget {options.budget} spent"
    if log.interrupted:
        return "interrupted"
    if log.missing:
        return "race rows not stored (--analyse runs nothing)"
    return ""


def _unit_map(success: pd.DataFrame, unit: Unit) -> pd.DataFrame:
    return frame_of(success[(success["task"] == unit.task) & (success["context"] == unit.context)])


__all__ = ["OPTIONS_FILE", "RACE_KEYS", "TuneOptions", "TuneResult", "analyse", "lines", "tune"]
