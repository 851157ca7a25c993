"""``harness tune --check TUNE_DIR``: a finished tune's decisions tested on fresh paired seeds.

The tune's own evidence comes from the race's seeds, which chose when to stop; a decision that
holds should hold again on seeds that neither the screening nor the race used. Per unit of the
tune's ``decisions.csv`` (robot, arm, object) the check runs two settings on the same N fresh
seeds of a new sweep seed (paired: common random numbers, as the race):

- the **current** setting, and
- for a *switch*, the **tuned** setting (what ``--write`` put in the task file); for a *keep*,
  *undecided* or *no setting helps*, the race's **best challenger** (the highest rate on the
  race's seeds among the challengers that never fell back to the reference's unfiltered rows;
  ties: screening order), so a missed gain shows.

Then per unit: both rates with exact (Clopper-Pearson) 95% intervals, the paired discordant
counts, the two-sided exact McNemar p-value (``harness.report.stats.mcnemar_exact``: the exact
binomial test of the discordant seeds against 1/2), Holm's correction over the units that ran a
second setting (``harness.tuning.decide.holm``, statsmodels' ``multipletests(method="holm")``
numbers), the paired gain with Newcombe's interval, and a verdict:

- a switch is **confirmed** (tuned better, Holm p < 0.05), **not confirmed** (no significant
  difference) or **contradicted** (tuned significantly worse);
- a keep / undecided / no setting helps **held** (the best challenger is not significantly
  better) or shows a **missed gain** (it is);
- ``inside_tune_interval``: whether the decided setting's fresh-seed rate (the tuned one for a
  switch, else the current one) lies in the 95% interval the tune quoted for it.

Seeds: an episode's seed is ``SeedSequence([sweep seed, index])`` (``harness.episode.ids``), so
two sweep seeds share no episode seed and a check's seeds overlap the tune's exactly when its
sweep seed is the screening's or the race's: that seed is refused with one line. The check's
episodes run through the race's runner (``harness.tuning.race.RaceRunner``: the sweep executor,
as for sweeps) in their own run directory
(default ``<tune>/check``); a rerun with the same options reuses every stored episode, and an
interrupted check decides nothing (its rows are kept; the same command continues it).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from harness.config import SweepConfig
from harness.errors import HarnessError
from harness.markdown import markdown_table
from harness.report.build import build_report
from harness.report.finish import finish_run
from harness.report.frames import frame_of
from harness.report.stats import mcnemar_exact
from harness.report.tune_link import check_rows
from harness.runs.expansion import load_sweep_tasks
from harness.runs.rundir import RunDir
from harness.tuning.check_overrides import override_units
from harness.tuning.decide import SWITCH, Racer, UnitRace, holm
from harness.tuning.decisions import setting_label
from harness.tuning.grid import merged_sweep
from harness.tuning.intervals import exact_interval, paired_gain_interval
from harness.tuning.options import OPTIONS_FILE, TuneOptions
from harness.tuning.planning import unit_key
from harness.tuning.race import CONFIRM_SEED_OFFSET, Budget, RaceLog, RaceRunner, Unit
from harness.tuning.sequential import Plan
from harness.writes import check_outputs, write_file

CHECK_DIR = "check"  # the check's run directory under the tune's, unless --out says otherwise
CHECK_SEED_OFFSET = 200_000  # the default sweep seed: the screening's + this (the race: + 100000)
DEFAULT_EPISODES = 100
CHECK_OUTPUTS = ("check.csv", "check.md")
ALPHA = 0.05  # two-sided, Holm over the units
CONFIRMED, NOT_CONFIRMED, CONTRADICTED = "confirmed", "not confirmed", "contradicted"
HELD, MISSED_GAIN, NO_CHALLENGER = "held", "missed gain", "no challenger"
# The decisions.csv columns the check reads (harness.tuning.decisions.unit_row writes them).
DECISION_COLUMNS = (
    "task",
    "context",
    "robot",
    "arm",
    "object",
    "verdict",
    "approach",
    "facing",
    "current_approach",
    "current_facing",
    "lo",
    "hi",
    "current_lo",
    "current_hi",
)
NO_CANDIDATE_NAN = ("successes", "rate", "lo", "hi", "gain", "gain_lo", "gain_hi", "p")
RACE_COLUMNS = ("task", "context", "current", "screen_rank", "n", "successes", "fallback")


@dataclass(frozen=True)
class CheckUnit:
    """One unit's check: its current setting and the setting it is tested against."""

    task: str
    context: str
    names: dict[str, str]  # robot, arm, object
    verdict: str  # the tune's
    current: tuple[str, str]
    candidate: tuple[str, str] | None  # None: the race had no challenger to test
    role: str  # "tuned" (a switch) or "best challenger"
    tune_interval: tuple[float, float]  # the tune's 95% interval of the decided setting's rate


@dataclass(frozen=True)
class CheckResult:
    """Where the check ran and what it found (``table`` empty when it was interrupted)."""

    run_dir: Path
    interrupted: bool
    table: pd.DataFrame = field(default_factory=pd.DataFrame)
    csv: Path = Path()
    md: Path = Path()


def _read_csv(path: Path, columns: tuple[str, ...], what: str) -> pd.DataFrame:
    """A tune output, checked: missing, unreadable or lacking a column is one line naming it."""
    if not path.is_file():
        raise HarnessError(f"{path}: no {what}; is this a finished tune directory?")
    try:
        table = pd.read_csv(path, dtype={"task": str, "context": str})
    except (OSError, UnicodeDecodeError, ValueError, pd.errors.ParserError) as error:
        raise HarnessError(f"{path}: not a tune's {what} ({error})") from None
    missing = [c for c in columns if c not in table.columns]
    if missing:
        raise HarnessError(f"{path}: not a tune's {what}: column {missing[0]!r} is missing")
    if table.empty:
        raise HarnessError(f"{path}: the {what} holds no unit")
    return table


def read_decisions(tune_dir: Path) -> pd.DataFrame:
    """``<tune>/tune/decisions.csv`` with the columns the check needs."""
    return _read_csv(tune_dir / "tune" / "decisions.csv", DECISION_COLUMNS, "decisions.csv")


def tune_seeds(tune_dir: Path) -> dict[str, int]:
    """The sweep seeds the tune used: its screening passes' and its race's."""
    seeds: dict[str, int] = {}
    for name in ("screen", "refine", "confirm", "exceptions"):
        run = RunDir(tune_dir / name)
        if run.sweep_yaml.is_file():
            seeds[name] = int(run.load_sweep().seed)
    if "screen" not in seeds:
        raise HarnessError(f"{tune_dir / 'screen'}: no screening run; not a tune directory")
    seeds.setdefault("confirm", seeds["screen"] + CONFIRM_SEED_OFFSET)
    return seeds


def refuse_overlap(seed: int, seeds: dict[str, int], tune_dir: Path) -> None:
    """One line when ``seed`` is a sweep seed the tune used (its episode seeds would repeat)."""
    used = {
        "screen": "screening",
        "refine": "refine pass",
        "confirm": "race",
        "exceptions": "exception tests",
    }
    for name, value in seeds.items():
        if value == seed:
            free = max(seeds.values()) + CHECK_SEED_OFFSET
            raise HarnessError(
                f"--seed {seed}: the tune {tune_dir} used sweep seed {seed} for its {used[name]} "
                f"({name}/sweep.yaml); a check needs seeds the tune never saw: give another "
                f"--seed (e.g. {free})"
            )


def _best_challenger(race: pd.DataFrame, task: str, context: str) -> int | None:
    """The screening rank of the race's best challenger of a unit (None: it had none)."""
    rows = frame_of(race[(race["task"] == task) & (race["context"] == context)])
    rows = frame_of(
        rows[~rows["current"].astype(bool) & ~rows["fallback"].astype(bool) & (rows["n"] > 0)]
    )
    if rows.empty:
        return None
    rate = rows["successes"] / rows["n"]
    best = rows.assign(rate=rate).sort_values(["rate", "screen_rank"], ascending=[False, True])
    return int(best.iloc[0]["screen_rank"])


def check_units(
    decisions: pd.DataFrame, race: pd.DataFrame, options: TuneOptions, tune_dir: Path
) -> list[CheckUnit]:
    """Per decision row, what the check runs: the current setting and the tuned one (switch) or
    the race's best challenger (the tune.json plan's racers, by screening rank)."""
    units = []
    for row in decisions.to_dict("records"):
        task, context = str(row["task"]), str(row["context"])
        current = (str(row["current_approach"]), str(row["current_facing"]))
        names = {k: str(row[k]) for k in ("robot", "arm", "object")}
        if row["verdict"] == SWITCH:
            candidate, role = (str(row["approach"]), str(row["facing"])), "tuned"
            interval = (float(row["lo"]), float(row["hi"]))
        else:
            candidate, role = None, "best challenger"
            interval = (float(row["current_lo"]), float(row["current_hi"]))
            rank = _best_challenger(race, task, context)
            plan = options.plans.get(unit_key(task, context), {})
            chosen = plan.get("challengers") or []
            if rank is not None and 1 <= rank <= len(chosen):
                candidate = (str(chosen[rank - 1][0]), str(chosen[rank - 1][1]))
            elif rank is not None:
                raise HarnessError(
                    f"{tune_dir / OPTIONS_FILE}: unit {unit_key(task, context)!r} has no "
                    f"challenger of screening rank {rank} (race.csv names it)"
                )
        for setting in (current, candidate or current):
            _check_setting(setting, tune_dir, task)
        units.append(
            CheckUnit(task, context, names, str(row["verdict"]), current, candidate, role, interval)
        )
    return units + override_units(tune_dir, decisions, CheckUnit, _check_setting)


def unit_name(unit: CheckUnit) -> str:
    return " ".join(unit.names[k] for k in ("robot", "arm", "object"))


def select_units(units: list[CheckUnit], only: list[str] | None, tune_dir: Path) -> list[CheckUnit]:
    """The units named in ``only`` (all when None); an unknown name is one line listing the
    tune's units."""
    if not only:
        return units
    names = [unit_name(u) for u in units]
    unknown = [name for name in only if name not in names]
    if unknown:
        raise HarnessError(
            f"--unit {unknown[0]!r}: {tune_dir} has no such unit (its units: {', '.join(names)})"
        )
    return [u for u, name in zip(units, names, strict=True) if name in only]


def _check_setting(setting: tuple[str, str], tune_dir: Path, task: str) -> None:
    """One line when a stored setting is not the JSON of a filter value (a hand-edited file)."""
    for text in setting:
        try:
            json.loads(text)
        except ValueError:
            raise HarnessError(
                f"{tune_dir / 'tune' / 'decisions.csv'}: task {task!r}: setting {text!r} is not "
                "a filter value (JSON, as the tune writes it)"
            ) from None


def paired_stats(current: list[bool], candidate: list[bool]) -> dict[str, Any]:
    """Rates with exact 95% intervals, discordant counts, the two-sided exact McNemar p and the
    paired gain (Newcombe) of ``candidate`` over ``current`` on the same seeds."""
    n = min(len(current), len(candidate))
    a, b = current[:n], candidate[:n]
    both = sum(x and y for x, y in zip(a, b, strict=True))
    only_new = sum(y and not x for x, y in zip(a, b, strict=True))
    only_current = sum(x and not y for x, y in zip(a, b, strict=True))
    k_cur, k_new = int(sum(a)), int(sum(b))
    cur_lo, cur_hi = exact_interval(k_cur, n)
    new_lo, new_hi = exact_interval(k_new, n)
    gain_lo, gain_hi = paired_gain_interval(
        both, only_new, only_current, n - both - only_new - only_current
    )
    return {
        "n": n,
        "current_successes": k_cur,
        "current_rate": k_cur / n if n else math.nan,
        "current_lo": float(cur_lo),
        "current_hi": float(cur_hi),
        "successes": k_new,
        "rate": k_new / n if n else math.nan,
        "lo": float(new_lo),
        "hi": float(new_hi),
        "only_new": int(only_new),
        "only_current": int(only_current),
        "gain": (only_new - only_current) / n if n else math.nan,
        "gain_lo": float(gain_lo),
        "gain_hi": float(gain_hi),
        "p": mcnemar_exact(int(only_current), int(only_new)).p_value,
    }


def check_verdict(tune_verdict: str, only_new: int, only_current: int, p_holm: float) -> str:
    """The check's verdict of one unit from its discordant counts and Holm-adjusted p-value."""
    significant = p_holm < ALPHA
    if tune_verdict == SWITCH:
        if significant:
            return CONFIRMED if only_new > only_current else CONTRADICTED
        return NOT_CONFIRMED
    return MISSED_GAIN if significant and only_new > only_current else HELD


def check_table(
    units: list[CheckUnit], outcomes: list[tuple[list[bool], list[bool]]]
) -> pd.DataFrame:
    """The check's rows: per unit its paired statistics, Holm over the units with a candidate,
    the verdict and whether the decided setting's fresh rate lies in the tune's interval."""
    rows = []
    for unit, (current, candidate) in zip(units, outcomes, strict=True):
        stats = paired_stats(current, candidate if unit.candidate else current)
        if unit.candidate is None:  # only the current setting ran: no second rate, no test
            stats.update({k: math.nan for k in NO_CANDIDATE_NAN})
            stats.update(only_new=0, only_current=0)
        decided = stats["rate"] if unit.verdict == SWITCH else stats["current_rate"]
        lo, hi = unit.tune_interval
        inside = lo <= decided <= hi if not (math.isnan(lo) or math.isnan(decided)) else None
        rows.append(
            {
                **unit.names,
                "task": unit.task,
                "context": unit.context,
                "tune_verdict": unit.verdict,
                "tested": unit.role if unit.candidate else "",
                "current_setting": setting_label(unit.current),
                "setting": setting_label(unit.candidate) if unit.candidate else "",
                "approach": unit.candidate[0] if unit.candidate else "",
                "facing": unit.candidate[1] if unit.candidate else "",
                **stats,
                "tune_lo": lo,
                "tune_hi": hi,
                "inside_tune_interval": inside,
            }
        )
    table = pd.DataFrame(rows)
    tested = [i for i, u in enumerate(units) if u.candidate and table.loc[i, "n"] > 0]
    adjusted = holm([float(table.loc[i, "p"]) for i in tested], ALPHA)[1] if tested else []
    table["p_holm"] = math.nan
    table["verdict"] = NO_CHALLENGER
    for i, p in zip(tested, adjusted, strict=True):
        table.loc[i, "p_holm"] = p
        row = table.loc[i]
        table.loc[i, "verdict"] = check_verdict(
            str(row["tune_verdict"]), int(row["only_new"]), int(row["only_current"]), p
        )
    for i, unit in enumerate(units):  # a candidate with no stored seed: nothing tested
        if unit.candidate and i not in tested:
            table.loc[i, "verdict"] = NOT_CONFIRMED if unit.verdict == SWITCH else HELD
    return table


class CheckRunner(RaceRunner):
    """The race's runner on the check's sweep seed: same points, same executor, other seeds."""

    round_label = "tune check"

    def __init__(self, run_dir: Path, screen: SweepConfig, seed: int, **kwargs: Any) -> None:
        super().__init__(run_dir, screen, **kwargs)
        data = self.sweep.model_dump(mode="json")
        data.update(name=f"{screen.name}-check", seed=seed)
        self.sweep = SweepConfig.model_validate(data)


def _refuse_changed(run_dir: Path, seed: int, episodes: int) -> None:
    """A check continued on the same directory keeps its sweep seed and seeds (one test)."""
    run = RunDir(run_dir)
    if not run.sweep_yaml.is_file():
        return
    stored = run.load_sweep()
    if stored.seed != seed or stored.episodes_per_point != episodes:
        raise HarnessError(
            f"{run.sweep_yaml}: this check ran sweep seed {stored.seed} with "
            f"{stored.episodes_per_point} episodes; give --seed {stored.seed} --episodes "
            f"{stored.episodes_per_point} to continue it, or another --out for a new check"
        )


def run_check(
    tune_dir: Path,
    *,
    seed: int | None = None,
    episodes: int = DEFAULT_EPISODES,
    workers: int = 1,
    out: Path | None = None,
    backend: str = "process",
    progress: bool = False,
    only: list[str] | None = None,
) -> CheckResult:
    """Run (or continue) the check of the tune in ``tune_dir`` and write ``check.csv`` and
    ``check.md`` in its run directory (``out``, default ``<tune>/check``). ``only``: the units
    to check (``"robot arm object"``; default every unit), Holm over those alone: a follow-up
    test of a unit an earlier check left unconfirmed, on seeds of its own (a new ``--seed``)."""
    options_path = tune_dir / OPTIONS_FILE
    if not options_path.is_file():
        raise HarnessError(f"{tune_dir}: not a tune directory (no {OPTIONS_FILE})")
    options = TuneOptions.load(options_path)
    decisions = read_decisions(tune_dir)
    race = _read_csv(tune_dir / "tune" / "race.csv", RACE_COLUMNS, "race.csv")
    seeds = tune_seeds(tune_dir)
    seed = seed if seed is not None else seeds["screen"] + CHECK_SEED_OFFSET
    refuse_overlap(seed, seeds, tune_dir)
    out = out or tune_dir / CHECK_DIR
    if out.exists():  # a planted link or special file: refused before any episode
        check_outputs(out, CHECK_OUTPUTS)
    _refuse_changed(out, seed, episodes)
    units = select_units(check_units(decisions, race, options, tune_dir), only, tune_dir)
    screen = RunDir(tune_dir / "screen")
    sweep = screen.load_sweep()
    refine = RunDir(tune_dir / "refine")
    if refine.sweep_yaml.is_file():
        sweep = merged_sweep(sweep, refine.load_sweep())
    tasks = load_sweep_tasks(sweep, screen.sweep_yaml)
    runner = CheckRunner(
        out,
        sweep,
        seed,
        tasks=tasks,
        max_seeds=episodes,
        objective=options.objective,
        backend=backend,
        workers=workers,
        may_run=True,
        progress=progress,
    )
    members = [_members(options, u) for u in units]
    races = [_race(u, episodes * max(1, len(m))) for u, m in zip(units, members, strict=True)]
    log = RaceLog()
    runner.open()
    try:  # a template unit runs ``episodes`` seeds on each of its objects (paired, pooled)
        checked = [
            Unit(u.task, u.context, r, members=m)
            for u, r, m in zip(units, races, members, strict=True)
        ]
        runner.round(checked, Budget(), log)
    finally:
        runner.close()
    if log.interrupted:
        return CheckResult(out, True)
    finish_run(out, options.objective)
    outcomes = [
        (r.racers[0].outcomes, r.racers[1].outcomes if len(r.racers) > 1 else []) for r in races
    ]
    table = check_table(units, outcomes)
    header = _header(tune_dir, seed, episodes, options.objective)
    if only:
        header.append(f"Only the units {', '.join(only)} (`--unit`): Holm over these alone.")
    csv = write_file(out / "check.csv", table.to_csv(index=False), root=out)
    md = write_file(out / "check.md", check_markdown(table, header), root=out)
    page = tune_dir / "screen" / "report.html"
    if out.resolve() == (tune_dir / CHECK_DIR).resolve() and page.is_file():
        build_report(page.parent, objective=options.objective)  # the tune's page shows it
    return CheckResult(out, False, table, csv, md)


def _members(options: TuneOptions, unit: CheckUnit) -> tuple[tuple[str, str], ...]:
    """A template unit's (task, context) members, from its stored plan; () for one task."""
    if unit.role == "override":
        return ()
    stored = options.plans.get(unit_key(unit.task, unit.context), {}).get("members") or []
    return tuple((str(t), str(c)) for t, c in stored)


def _race(unit: CheckUnit, episodes: int) -> UnitRace:
    """A one-look "race" that only runs the unit's settings on ``episodes`` seeds."""
    racers = [Racer(unit.current, 0)]
    if unit.candidate is not None:
        racers.append(Racer(unit.candidate, 1))
    return UnitRace(racers, Plan(seeds=episodes, block=episodes))


def _header(tune_dir: Path, seed: int, episodes: int, objective: str) -> list[str]:
    return [
        f"harness tune --check {tune_dir}: {episodes} fresh paired seeds per setting (sweep seed "
        f"{seed}, objective {objective}); per unit the current setting against "
        "the tuned one (switch) or the race's best challenger (otherwise); two-sided exact "
        f"McNemar on the discordant seeds, Holm over the units at {ALPHA}; rates with exact 95% "
        "intervals, the gain with Newcombe's paired interval.",
    ]


def check_markdown(table: pd.DataFrame, header_lines: list[str]) -> str:
    head, rows = check_rows(table)
    lines = ["# Tune check on fresh seeds", "", *header_lines, "", *markdown_table(head, rows)]
    notes = (
        "`+/-`: seeds only the tested setting / only the current one succeeded on. `in tune CI`: "
        "whether the decided setting's fresh rate (tuned for a switch, else current) lies in "
        "the tune's 95% interval. Every column is in `check.csv`."
    )
    return "\n".join([*lines, "", notes, ""])


def check_lines(table: pd.DataFrame, emit: Callable[[str], None]) -> None:
    """Print the compact table as aligned plain text."""
    head, rows = check_rows(table)
    widths = [max(len(str(c)) for c in column) for column in zip(head, *rows, strict=True)]
    for cells in (head, *rows):
        emit("  ".join(str(c).ljust(w) for c, w in zip(cells, widths, strict=True)).rstrip())
