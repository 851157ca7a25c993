"""Running the race: each round, every unit's alive racers on the next block of fresh seeds.

The race lives in its own run directory (``<tune>/confirm``) whose ``sweep.yaml`` is the
screening sweep with another sweep seed (``CONFIRM_SEED_OFFSET`` added) and ``max_seeds``
episodes per point: every race episode is an episode of that sweep (same ids, same seeds), so
the confirmation seeds are fresh (no screening seed among them), the racers of a unit share each
seed (common random numbers; points that differ only in filters share the seed's candidate
evaluations) and a rerun of the tune skips what the directory already holds.

With a ``fill`` a round also runs the blocks of the looks after it, as long as the round stays
within the fill, and stores them; the looks are still applied one at a time, each on its own
block only, so the test and its decisions are those of one look per round (a race that stops
early leaves its later blocks stored and unused). The tune runs without a fill (0): on CPU
cores every episode costs a core's time, so running looks ahead saves nothing.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from harness.config import SweepConfig, TaskConfig, apply_overrides
from harness.episode.ids import episode_seed
from harness.episode.spec import EpisodeSpec
from harness.errors import HarnessError
from harness.runs.executors import executor_for
from harness.runs.expansion import point_overrides, sweep_points
from harness.runs.progress import SweepProgress
from harness.runs.rundir import RunDir
from harness.tuning.decide import UnitRace, update
from harness.tuning.grid import APPROACH_KEY, FACING_KEY

CONFIRM_SEED_OFFSET = 100_000


@dataclass(frozen=True)
class Budget:
    """When the race stops at the latest: episodes run, or episode-seconds (the sum of the rows'
    ``wall_time_s``: each episode runs on one core, so on an idle machine this is its CPU time;
    on a loaded one it is more), over the whole race; None: no limit but ``max_seeds``."""

    episodes: int | None = None
    seconds: float | None = None

    @staticmethod
    def parse(text: str | None) -> Budget:
        """``"400"`` (episodes) or ``"300s"`` (CPU seconds); anything else, zero or negative is
        refused with one line naming ``--budget``."""
        if text is None:
            return Budget()
        value = str(text).strip()
        try:
            number = float(value[:-1]) if value.endswith("s") else int(value)
        except ValueError:
            number = math.nan
        if not number > 0 or math.isinf(number):
            raise HarnessError(
                f"--budget {text!r}: expected a positive number of race episodes (400) or "
                "episode-seconds (300s)"
            )
        if value.endswith("s"):
            return Budget(seconds=float(number))
        return Budget(episodes=int(number))

    def spent(self, episodes: int, seconds: float) -> bool:
        return (self.episodes is not None and episodes >= self.episodes) or (
            self.seconds is not None and seconds >= self.seconds
        )

    def allows(self, episodes: int, seconds: float, more: int, seconds_each: float) -> bool:
        """Whether a round of ``more`` episodes (``seconds_each`` each, estimated) fits in what
        is left after ``episodes`` / ``seconds``: the budget bounds the race's episodes."""
        if self.episodes is not None and episodes + more > self.episodes:
            return False
        return self.seconds is None or seconds + more * seconds_each <= self.seconds


@dataclass
class Unit:
    """One race: a task and one value of the other axes (its object), or a template group's
    tasks (``members``, one object each) raced as one unit with the objects as strata.

    A member is a (task, context) pair: a reference folder's files (one object each) or one
    task's objects (the values of its sweep's ``object.mesh`` axis, ``harness tune --template``).
    A template unit's look gives every alive racer the same seeds on every member (its plan
    counts (object, seed) pairs: ``plan.seeds`` and ``plan.block`` are multiples of the member
    count), so each racer's outcomes are paired across racers object by object and the exact
    McNemar test of :mod:`harness.tuning.decide` on the pooled pairs tests the mean gain over
    the objects, each object weighted equally (equal seeds per object)."""

    task: str  # the task, or the template group's name
    context: str  # JSON of the point's other axes
    race: UnitRace
    rows: list[dict[str, Any]] = field(default_factory=list)  # its race rows, every racer
    members: tuple[tuple[str, str], ...] = ()  # a template's (task, context) pairs; () for one

    @property
    def strata(self) -> tuple[tuple[str, str], ...]:
        """The (task, context) pairs the unit's looks run: its members, or its own pair."""
        return self.members or ((self.task, self.context),)

    @property
    def is_template(self) -> bool:
        return bool(self.members)


@dataclass
class RaceLog:
    """What the race ran: episodes, CPU seconds, rounds, and whether it was cut short."""

    episodes: int = 0
    seconds: float = 0.0
    rounds: int = 0
    ran_ahead: int = 0  # episodes run for later looks than their round's (``fill``)
    budget_spent: bool = False
    interrupted: bool = False
    missing: bool = False  # --analyse: a block the race needs is not stored
    rows: list[dict[str, Any]] = field(default_factory=list)


def episodes_left(units: list[Unit]) -> int:
    """The most episodes the races still running can ask for: each running unit's seeds not
    yet raced, times its live racers (a race that stops early asks for fewer)."""
    return sum(
        (u.race.plan.seeds - u.race.seeds_of(u.race.look)) * len(u.race.alive())
        for u in units
        if not u.race.stopped
    )


def pace_line(round_number: int, ran: int, seconds: float, left: int) -> str:
    """After a race round: what it ran, in how long, and what the rest costs at that pace (the
    up-front estimate uses the screening's pace, which shares seeds across more settings)."""
    line = f"race round {round_number}: {ran:,} episodes in {_duration(seconds)}"
    if not left:
        return line + "; no race asks for more"
    return (
        f"{line}; the races still running ask for at most {left:,} more: at this pace up to "
        f"{_duration(left * seconds / max(1, ran))}"
    )


def _duration(seconds: float) -> str:
    return f"{seconds / 60.0:.1f} min" if seconds >= 90 else f"{seconds:.0f} s"


def confirm_sweep(
    screen: SweepConfig, max_seeds: int, offset: int = CONFIRM_SEED_OFFSET, name: str = "confirm"
) -> SweepConfig:
    """The screening sweep with fresh seeds (sweep seed + ``offset``) and ``max_seeds``
    episodes per point."""
    data = screen.model_dump(mode="json")
    data.update(
        name=f"{screen.name}-{name}",
        seed=screen.seed + offset,
        episodes_per_point=max_seeds,
        record="none",
    )
    return SweepConfig.model_validate(data)


class RaceRunner:
    """Builds and runs the episodes of the rounds in ``run_dir`` (reusing stored rows)."""

    round_label = "race round"  # the progress line's name of a round

    def __init__(
        self,
        run_dir: Path,
        screen: SweepConfig,
        tasks: list[TaskConfig],
        max_seeds: int,
        *,
        objective: str,
        backend: str,
        workers: int,
        may_run: bool,
        progress: bool = False,
        seconds_each: float = 0.0,
        announce: Callable[[str], None] | None = None,
        fill: int = 0,
        seed_offset: int = CONFIRM_SEED_OFFSET,
        name: str = "confirm",
    ) -> None:
        """``progress``: each round's episodes as the sweep shows them (``SweepProgress``);
        ``announce``: a line per round with its pace and what the rest costs at it; ``fill``:
        the episodes a round may grow to with later looks' blocks (see the module)."""
        self.sweep = confirm_sweep(screen, max_seeds, seed_offset, name)
        self.run = RunDir(run_dir)
        self.tasks = {t.name: t for t in tasks}
        self.points = {
            json.dumps(p, sort_keys=True): i for i, p in enumerate(sweep_points(self.sweep))
        }
        self.objective, self.backend, self.workers, self.may_run = (
            objective,
            backend,
            workers,
            may_run,
        )
        self.progress = progress
        self.seconds_each = seconds_each
        self.announce = announce
        self.fill = fill
        self.configured: dict[tuple[str, str], TaskConfig] = {}
        self.stored: dict[str, dict[str, Any]] = {}

    def open(self) -> None:
        """Create (or reopen) the race's run directory and read the rows it holds."""
        if self.run.sweep_yaml.is_file():
            self.run = RunDir.existing(self.run.path, force=True)
            self.stored = {
                str(r["episode_id"]): r for r in self.run.store.load().to_dict("records")
            }
        elif self.may_run:
            self.run.create(self.sweep, list(self.tasks.values()), taken="")
        else:
            return

    def close(self) -> None:
        if self.run.sweep_yaml.is_file():
            self.run.finalize() if self.may_run else self.run.lock.release()

    def _spec(self, task: str, point: dict[str, Any], index: int) -> EpisodeSpec:
        key = json.dumps(point, sort_keys=True)
        configured = self.configured.get((task, key))
        if configured is None:
            base = self.tasks[task]
            configured = apply_overrides(base, point_overrides(base, point))
            self.configured[(task, key)] = configured
        return EpisodeSpec(
            task=configured,
            task_name=task,
            point_id=self.points.get(key, -1),
            point=point,
            episode_index=index,
            seed=episode_seed(self.sweep.seed, index),
            run=self.sweep.name,
        )

    def _look(self, unit: Unit, look: int) -> list[tuple[Any, list[EpisodeSpec]]]:
        """Each alive racer of ``unit`` with its specs of block ``look`` (0-based)."""
        count = len(unit.strata)  # a template unit's plan counts (object, seed) pairs
        start, stop = unit.race.seeds_of(look) // count, unit.race.seeds_of(look + 1) // count
        blocks = []
        for racer in unit.race.alive():
            filters = {
                APPROACH_KEY: json.loads(racer.setting[0]),
                FACING_KEY: json.loads(racer.setting[1]),
            }
            specs = [
                self._spec(task, {**filters, **json.loads(context)}, i)
                for task, context in unit.strata
                for i in range(start, stop)
            ]
            blocks.append((racer, specs))
        return blocks

    def _ahead(self, units: list[Unit], size: int) -> list[EpisodeSpec]:
        """The blocks of the looks after this round's, whole looks at a time (the same count
        for every unit, each within its plan), while the round stays within ``fill``."""
        ahead: list[EpisodeSpec] = []
        for step in range(1, max(u.race.looks for u in units)):
            later = [
                spec
                for unit in units
                if unit.race.look + step < unit.race.looks
                for _, specs in self._look(unit, unit.race.look + step)
                for spec in specs
            ]
            if not later or size + len(ahead) + len(later) > self.fill:
                break
            ahead.extend(later)
        return ahead

    def round(self, units: list[Unit], budget: Budget, log: RaceLog) -> bool:
        """Run the next block of every running unit (and, within ``fill``, the blocks of later
        looks) and apply the look; False if cut short (the budget would be overrun, a row is
        missing or the run was interrupted)."""
        wanted = [
            (racer, unit, specs)
            for unit in units
            for racer, specs in self._look(unit, unit.race.look)
        ]
        size = sum(len(specs) for _, _, specs in wanted)
        each = log.seconds / log.episodes if log.episodes else self.seconds_each
        if not budget.allows(log.episodes, log.seconds, size, each):
            log.budget_spent = True
            return False
        todo = [s for _, _, specs in wanted for s in specs if s.resolved_id not in self.stored]
        if todo and not self.may_run:
            log.missing = True
            return False
        ahead: list[EpisodeSpec] = []
        if todo and self.fill > size:
            ahead = [s for s in self._ahead(units, size) if s.resolved_id not in self.stored]
            if not budget.allows(log.episodes, log.seconds, size + len(ahead), each):
                ahead = []
            todo.extend(ahead)
            log.ran_ahead += len(ahead)
        clock = time.perf_counter()
        if todo:
            label = f"{self.round_label} {log.rounds + 1}"
            with SweepProgress(len(todo), 0, self.progress, label=label) as on_row:

                def store(row: dict[str, Any]) -> None:
                    self._store(row)
                    on_row(row)

                stats = executor_for(self.backend, self.workers)(
                    todo, self.run.path, "none", store, share=True
                )
            if stats.interrupted:
                log.interrupted = True
                return False
        verdict = "valid" if self.objective == "valid" else "success"
        for racer, unit, specs in wanted:
            rows = [self.stored[s.resolved_id] for s in specs]
            unit.rows.extend(rows)
            racer.outcomes.extend(bool(r.get(verdict)) for r in rows)
            racer.reference.extend(bool(r.get("success")) for r in rows)
            racer.strata.extend(stratum_of(s) for s in specs)
            racer.fallback = racer.fallback or any(
                r.get("filter_outcome") == "fallback" for r in rows
            )
            log.episodes += len(rows)
            log.seconds += sum(float(r.get("wall_time_s") or 0.0) for r in rows)
            log.rows.extend(rows)
        for unit in units:
            update(unit.race)
        log.rounds += 1
        if todo and self.announce is not None:
            elapsed = time.perf_counter() - clock
            line = pace_line(log.rounds, len(todo), elapsed, episodes_left(units))
            if ahead:
                line += f" ({len(ahead):,} of the round's episodes were later looks', run ahead)"
            self.announce(line)
        return True

    def _store(self, row: dict[str, Any]) -> None:
        self.run.append(row)
        self.stored[str(row["episode_id"])] = row


def stratum_of(spec: EpisodeSpec) -> str:
    """An episode's (task, context) as one key: ``task`` TAB the JSON of its point's other
    axes, as the screening's ``context`` (``harness.tuning.analysis.point_parts``)."""
    others = {k: v for k, v in spec.point.items() if k not in (APPROACH_KEY, FACING_KEY)}
    return f"{spec.task_name}\t{json.dumps(others, sort_keys=True)}"


def run_race(units: list[Unit], runner: RaceRunner, budget: Budget) -> RaceLog:
    """Rounds until every unit's race stopped, the budget is spent or the run is cut short."""
    log = RaceLog()
    runner.open()
    try:
        while running := [u for u in units if not u.race.stopped]:
            if not runner.round(running, budget, log):
                break
    finally:
        runner.close()
    return log
