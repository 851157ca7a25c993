"""A unit's race plan from its screening: the seeds that give the race 80% power for the
target gain, and the lines that say so up front (seeds, minutes on this engine, what a
``--budget`` lets the race see)."""

from __future__ import annotations

import math
from typing import Any

import pandas as pd

from harness.report.frames import frame_of
from harness.tuning.options import TuneOptions
from harness.tuning.race import Budget, Unit
from harness.tuning.sequential import (
    MAX_LOOKS,
    Plan,
    correlated_discordance,
    plan_block,
    seeds_for_power,
)

OUTCOME_CORRELATION = 0.45  # settings' outcome correlation on a seed, measured (issue 23)


def unit_key(task: str, context: str) -> str:
    """A unit's key in ``tune.json``'s plans."""
    return f"{task}\t{context}"


def screening_discordance(
    settings: pd.DataFrame,
    unit: tuple[str, str],
    current: tuple[str, str],
    others: list[tuple[str, str]],
) -> float:
    """Mean share of screening seeds on which a raced challenger and the current setting
    disagree (the screening's settings share each seed): NaN without pairs."""
    rows = frame_of(settings[(settings["task"] == unit[0]) & (settings["context"] == unit[1])])

    def outcomes(setting: tuple[str, str]) -> pd.Series:
        at = frame_of(rows[(rows["approach"] == setting[0]) & (rows["facing"] == setting[1])])
        return pd.Series(at.groupby("episode_index")["ok"].first())

    base = outcomes(current)
    shares = []
    for other in others:
        pair = pd.concat([base, outcomes(other)], axis=1, join="inner")
        if len(pair):
            shares.append(float((pair.iloc[:, 0] != pair.iloc[:, 1]).mean()))
    return float(sum(shares) / len(shares)) if shares else math.nan


def make_plan(rate: float, discordance: float, options: TuneOptions, challengers: int) -> Plan:
    """A unit's race plan: ``max_seeds`` when given, else the seeds that give 80% power to
    confirm a ``target_gain`` gain over the current setting's screening ``rate`` (clipped to
    0.05-0.95), at the larger of the screening's discordance and the one outcome correlation
    0.45 implies (issue 23's measurement), Holm's first step over the challengers."""
    base = min(max(rate, 0.05), 0.95)
    gain = options.target_gain
    psi = correlated_discordance(base, gain, OUTCOME_CORRELATION)
    if not math.isnan(discordance):
        psi = max(psi, discordance)
    psi = round(psi, 2)
    share = options.alpha / max(1, challengers)
    seeds = options.max_seeds or seeds_for_power(gain, psi, options.block, share)
    block = plan_block(seeds, options.block, MAX_LOOKS)
    return Plan(seeds, block, options.alpha, max(1, challengers), gain, psi)


def plan_of(stored: dict[str, Any], options: TuneOptions, challengers: int) -> Plan:
    return Plan(
        int(stored["seeds"]),
        int(stored["block"]),
        options.alpha,
        max(1, challengers),
        options.target_gain,
        float(stored["discordance"]),
    )


def plan_lines(
    units: list[Unit], names: dict[tuple[str, str], dict[str, str]], options: TuneOptions
) -> list[str]:
    """Up front, per unit: the seeds its race needs, the minutes that costs on this engine
    (the screening's measured seconds per episode), and what a ``--budget`` lets it see."""
    budget = Budget.parse(options.budget)
    rounds = rounds_allowed(budget, units, options.seconds_each)
    out = []
    for unit in units:
        plan, label = unit.race.plan, names[(unit.task, unit.context)]
        head = f"{label['robot']} {label['arm']} {label['object']}: "
        episodes = plan.seeds * len(unit.race.racers)
        seconds = episodes * options.seconds_each
        took = f"{seconds / 60.0:.0f} minutes" if seconds >= 90 else f"{seconds:.0f} s"
        how = (
            f"--max-seeds {options.max_seeds}"
            if options.max_seeds
            else f"80% power for a {plan.target_gain * 100:+.0f}-point gain at the screening's "
            f"rate, discordance {plan.discordance:.2f}"
        )
        count = len(unit.strata)
        seeds = (
            f"~{plan.seeds} (object, seed) pairs per contender, {plan.seeds // count} seeds on "
            f"each of {count} objects"
            if unit.is_template
            else f"~{plan.seeds} seeds per contender"
        )
        line = (
            f"{head}this race needs {seeds} ({how}; "
            f"{plan.looks} looks of {plan.block}): ~{took} on this engine "
            f"({len(unit.race.racers)} racers at the screening's {options.seconds_each:.2f} s "
            "per episode; the screening shares each seed across many settings, the race across "
            "a few, so its episodes can cost more)"
        )
        if rounds is not None and rounds < plan.looks:
            looks = rounds
            seen = plan.detectable(looks) if looks else math.inf
            line += f"; --budget {options.budget} allows " + (
                f"at least {looks} looks ({looks * plan.block} seeds): it can see a gain of "
                f"{seen * 100:+.0f} points or more at 80% power"
                if math.isfinite(seen)
                else f"at least {looks} looks ({looks * plan.block} seeds): too few to confirm "
                "any gain at 80% power"
                if looks
                else f"no look (one look is {plan.block} seeds x {len(unit.race.racers)} "
                "racers): it decides nothing"
            )
        out.append(line)
    return out


def rounds_allowed(budget: Budget, units: list[Unit], seconds_each: float) -> int | None:
    """Looks the budget lets every unit have while all of them race (None: no budget).

    The race's own rule (``RaceRunner.round``, ``Budget.allows``): a round runs every racing
    unit's next block of seeds with each of its racers, and only when all of that round fits in
    what is left. So each unit gets as many looks as whole rounds fit, whatever its block; a
    unit that stops early leaves more for the rest (then they may get more looks than this).
    Sharing the budget evenly per seed instead told a unit with a long block that it got no
    look when the race gave it one (the canonical tune with ``--budget 1600``: 4 racers x 72
    seeds of Lift-2 left banana ran in a round of 1,360 episodes)."""
    per_round = sum(unit.race.plan.block * len(unit.race.racers) for unit in units)
    if per_round <= 0:
        return None
    if budget.episodes is not None:
        return budget.episodes // per_round
    if budget.seconds is not None and seconds_each > 0:
        return int(budget.seconds / (per_round * seconds_each))
    return None
