"""The tune's decision: a race of the screening's best settings against the current one on fresh
seeds, and its verdict ("keep current", "switch", "undecided within budget" or "no setting
helps").

Pure logic over paired outcomes (no episodes run here; ``harness.tuning.race`` feeds it). One
*unit* is one robot, arm and object; its racers are the current setting and the few best
settings of the screening. Every racer alive in a round runs the round's block of fresh seeds,
so all alive racers share every seed (common random numbers) and each comparison is paired.
The race follows its unit's :class:`~harness.tuning.sequential.Plan` (planned seeds, looks,
alpha), fixed before the first look, so a race continued on the same ``--out`` is one test.

After each round (a *look*):

- **claims**: each alive challenger c not yet confirmed against the current setting, the exact
  one-sided McNemar test (binomial tail of c-only successes among the discordant seeds, p = 1/2),
  Holm's step-down over the challengers the race started with less those already confirmed,
  each step at the group-sequential nominal level of the look for alpha / (hypotheses left)
  (``Plan.level``; Holm in a group-sequential design as in Maurer & Bretz 2013, Stat. Biopharm.
  Res. 5:311). The chance of any false "better than current" over the whole race, continued or
  not, is at most alpha. A rejected challenger is *confirmed*.
- **elimination**: the leader (most successes; ties: the current, then screening order) against
  each other alive challenger, the same test (Holm at the look's level for alpha); a challenger
  the leader beats is dropped (Maron & Moore's Hoeffding races / Birattari's F-race). A racer
  that fell back to the reference's unfiltered rows is dropped at once: never recommended. The
  current setting is never dropped: it is the control every claim is paired with.

The race of a unit stops (:func:`stop_reason`) when a challenger is confirmed (decided), when
every racer's rate is below the floor (no setting helps), when no challenger is alive, when
every alive challenger's gain is shown below the plan's target (its Newcombe 95% upper bound
below ``target_gain`` at the look's nominal level: a gain that size is rejected), or after
the plan's last look. A race
the budget, an interruption or missing rows cut short did not stop by its own rule, and decides
nothing: "undecided" (never "keep").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.special import bdtrc

from harness.tuning.intervals import (
    exact_interval,
    paired_gain_bounds,
    paired_gain_interval,
    table,
)
from harness.tuning.sequential import Plan, seeds_for_power

KEEP = "keep current"
SWITCH = "switch"
UNDECIDED = "undecided within budget"
NO_SETTING_HELPS = "no setting helps"
VERDICTS = (KEEP, SWITCH, UNDECIDED, NO_SETTING_HELPS)
MIN_DISCORDANT = 5  # discordant seeds before Newcombe's bound may stop a race as "keep" (chosen)
FLOOR = 0.10  # "no setting helps": every racer's Wilson 95% upper bound below this (chosen)

STOP_CONFIRMED = "a challenger confirmed better"
STOP_FLOOR = f"every racer's 95% upper bound below {FLOOR:.0%}"
STOP_DROPPED = "every challenger dropped"
STOP_RULED_OUT = "every challenger's gain shown below the target"
STOP_PLAN = "the plan's seeds are spent"


@dataclass
class Racer:
    """One setting in a unit's race: its outcomes on the race seeds so far."""

    setting: tuple[str, str]
    rank: int  # screening order (0 = the current setting)
    outcomes: list[bool] = field(default_factory=list)
    reference: list[bool] = field(default_factory=list)  # the reference success, beside it
    strata: list[str] = field(default_factory=list)  # each outcome's "task\tcontext" (a stratum)
    alive: bool = True
    fallback: bool = False
    confirmed_at: int | None = None  # the look that confirmed it better than current
    dropped_at: int | None = None
    p_value: float = math.nan  # exact one-sided McNemar p at the look that confirmed it
    level: float = math.nan  # the Holm step's nominal level it was compared with

    @property
    def successes(self) -> int:
        return int(sum(self.outcomes))


@dataclass
class UnitRace:
    """The race of one unit: ``racers[0]`` is the current setting; ``plan`` its design."""

    racers: list[Racer]
    plan: Plan
    look: int = 0
    stopped: str = ""  # why the race of this unit stopped by its own rule ("" while it runs)

    @property
    def current(self) -> Racer:
        return self.racers[0]

    @property
    def looks(self) -> int:
        return self.plan.looks

    @property
    def alpha(self) -> float:
        return self.plan.alpha

    def alive(self) -> list[Racer]:
        """The racers that run the next block (the current setting always)."""
        return [r for r in self.racers if r.alive]

    def challengers(self) -> list[Racer]:
        return [r for r in self.racers[1:] if r.alive]

    def seeds_of(self, look: int) -> int:
        """Fresh seeds per racer after ``look`` looks."""
        return min(look * self.plan.block, self.plan.seeds)


def discordant(a: list[bool], b: list[bool]) -> tuple[int, int]:
    """(a-only, b-only) successes over the seeds both ran (the first ``min`` outcomes)."""
    won = lost = 0
    for x, y in zip(a, b, strict=False):
        won += x and not y
        lost += y and not x
    return int(won), int(lost)


def one_sided_mcnemar(better_only, worse_only):
    """Exact one-sided McNemar p-value that the first is better: P(B(d, 1/2) >= better_only)
    with d the discordant seeds (1 without any). ``scipy.special.bdtrc``, the binomial tail
    ``binomtest(..., alternative="greater")`` computes, so arrays work too."""
    if isinstance(better_only, int) and isinstance(worse_only, int):
        if better_only == 0:
            return 1.0
        return float(bdtrc(better_only - 1, better_only + worse_only, 0.5))
    won, lost = np.asarray(better_only), np.asarray(worse_only)
    total = won + lost
    p = np.where(won > 0, bdtrc(np.maximum(won - 1, 0), np.maximum(total, 1), 0.5), 1.0)
    return float(p) if p.ndim == 0 else p


def holm(p_values: list[float], level: float) -> tuple[list[bool], list[float]]:
    """Holm's step-down rejections and adjusted p-values, as statsmodels
    ``multipletests(method="holm")`` gives them (tests/test_tune_decide.py checks they agree).
    Computed here because ``multipletests`` runs ``gc.collect()`` on every Holm call
    (statsmodels/stats/multitest.py, 0.14-0.15): 0.1-0.7 s each in a process holding a tune."""
    order = np.argsort(p_values, kind="stable")
    m = len(p_values)
    steps = np.asarray(p_values, float)[order] * (m - np.arange(m))
    adjusted_sorted = np.minimum(np.maximum.accumulate(steps), 1.0)
    adjusted = np.empty(m)
    adjusted[order] = adjusted_sorted
    return [bool(p <= level) for p in adjusted], [float(p) for p in adjusted]


def leader(race: UnitRace) -> Racer:
    """Most successes among the alive; ties: the current, then screening rank."""
    return max(race.alive(), key=lambda r: (r.successes, r is race.current, -r.rank))


def _claims(race: UnitRace) -> None:
    """Holm's step-down over the hypotheses still open, at this look's nominal levels."""
    pending = [r for r in race.challengers() if r.confirmed_at is None]
    open_hypotheses = sum(r.confirmed_at is None for r in race.racers[1:])
    p_values = [
        float(one_sided_mcnemar(*discordant(r.outcomes, race.current.outcomes))) for r in pending
    ]
    for step, index in enumerate(np.argsort(p_values, kind="stable")):
        level = race.plan.level(race.look, open_hypotheses - step)
        racer = pending[int(index)]
        if p_values[index] > level:
            break
        racer.confirmed_at, racer.p_value, racer.level = race.look, p_values[index], level


def update(race: UnitRace) -> None:
    """Apply one look to a unit whose alive racers all hold the same number of outcomes."""
    race.look += 1
    for racer in race.challengers():
        if racer.fallback:
            racer.alive, racer.dropped_at = False, race.look
    _claims(race)
    best = leader(race)
    others = [r for r in race.challengers() if r is not best]
    beaten = [float(one_sided_mcnemar(*discordant(best.outcomes, r.outcomes))) for r in others]
    for racer, rejected in zip(others, holm(beaten, race.plan.level(race.look))[0], strict=True):
        if rejected and racer.confirmed_at is None:
            racer.alive, racer.dropped_at = False, race.look
    race.stopped = stop_reason(race)


def gain(racer: Racer, current: Racer) -> int:
    """Seeds won minus seeds lost against the current setting (paired)."""
    won, lost = discordant(racer.outcomes, current.outcomes)
    return won - lost


def rate_bounds(racer: Racer) -> tuple[float, float]:
    """The racer's exact (Clopper-Pearson) 95% interval on its fresh seeds."""
    lo, hi = exact_interval(racer.successes, len(racer.outcomes))
    return float(lo), float(hi)


def gain_interval(racer: Racer, current: Racer, confidence: float = 0.95) -> tuple[float, float]:
    """Newcombe's method-10 interval of the paired gain (``harness.tuning.intervals``)."""
    return paired_gain_bounds(*table(racer.outcomes, current.outcomes), confidence)


def futility_bound(won, lost, both, neither, level: float):
    """Upper bound of the paired gain at one-sided ``level``: Newcombe's (confidence
    1 - 2 level) with at least ``MIN_DISCORDANT`` discordant seeds; with fewer, Newcombe's
    interval collapses (phi near 1: zero width on identical outcomes), so the bound is the
    exact one-sided upper bound of the share of seeds only the challenger wins (the gain is
    at most that share). Arrays work (the simulation calls it)."""
    won, lost = np.asarray(won), np.asarray(lost)
    n = won + lost + np.asarray(both) + np.asarray(neither)
    newcombe = paired_gain_interval(both, won, lost, neither, 1.0 - 2.0 * level)[1]
    share = exact_interval(won, n, 1.0 - 2.0 * level)[1]
    bound = np.where(won + lost >= MIN_DISCORDANT, newcombe, share)
    return float(bound) if bound.ndim == 0 else bound


def gain_upper(race: UnitRace, racer: Racer) -> float:
    """:func:`futility_bound` of a challenger at the look's nominal level: below the plan's
    target, a gain that size is rejected at the race's own sequential level, so "keep" errs on
    a real target gain at most about alpha."""
    level = race.plan.level(race.look, 1)
    if level <= 0.0:
        return math.inf
    both, won, lost, neither = table(racer.outcomes, race.current.outcomes)
    return float(futility_bound(won, lost, both, neither, level))


def stop_reason(race: UnitRace) -> str:
    """Why the unit's race stops after this look by its own rule, or "" to go on."""
    challengers = race.challengers()
    if any(r.confirmed_at is not None for r in race.racers[1:]):
        return STOP_CONFIRMED
    if all(rate_bounds(r)[1] < FLOOR for r in race.alive()):
        return STOP_FLOOR
    if not challengers:
        return STOP_DROPPED
    if all(gain_upper(race, r) < race.plan.target_gain for r in challengers):
        return STOP_RULED_OUT
    if race.look >= race.plan.looks:
        return STOP_PLAN
    return ""


@dataclass(frozen=True)
class Verdict:
    """A unit's decision and its evidence (rates on the race's fresh seeds)."""

    verdict: str
    chosen: Racer | None  # the setting to switch to (None: keep / undecided / none helps)
    contenders: list[Racer]  # undecided: the challengers still ahead of current
    seeds: int  # fresh seeds the current setting ran
    seeds_needed: int  # undecided: paired seeds for 80% power at the gain seen (0: none)
    within_plan: bool  # seeds_needed lies on this race's plan (a rerun continues to it)
    detectable: float  # the gain the looks run see with 80% power (inf: none)
    reason: str


def changes(racer: Racer, current: Racer) -> int:
    """How many of the two filters (approach, facing) differ from the current setting's."""
    return sum(a != b for a, b in zip(racer.setting, current.setting, strict=True))


def pick(confirmed: list[Racer], current: Racer) -> Racer:
    """Among confirmed challengers: the highest rate on the fresh seeds, then the fewest
    filter changes from the current setting, then the screening order."""
    return max(confirmed, key=lambda r: (r.successes, -changes(r, current), -r.rank))


def verdict(race: UnitRace, why: str = "", evidence: bool = True) -> Verdict:
    """The decision of a unit race. A race that did not stop by its own rule (no look, the
    budget, an interruption, missing rows: ``why``) is undecided, never "keep". ``evidence``
    False skips the power computations (seeds needed, detectable gain): simulations."""
    current = race.current
    seeds = len(current.outcomes)
    discordance = race.plan.discordance
    ahead = [r for r in race.challengers() if gain(r, current) > 0 and not r.fallback]
    detectable = (
        race.plan.detectable(race.look, discordance) if race.look and evidence else math.inf
    )
    confirmed = [r for r in race.racers[1:] if r.confirmed_at is not None and not r.fallback]
    if confirmed:
        chosen = pick(confirmed, current)
        return Verdict(SWITCH, chosen, [], seeds, 0, True, detectable, race.stopped or why)
    if race.stopped == STOP_FLOOR:
        return Verdict(NO_SETTING_HELPS, None, [], seeds, 0, True, detectable, race.stopped)
    if race.stopped and not (race.stopped == STOP_PLAN and ahead):
        return Verdict(KEEP, None, [], seeds, 0, True, detectable, race.stopped)
    cut = "the race did not reach its first look" if race.look == 0 else "the race did not finish"
    reason = race.stopped or why or cut
    needed, within = seeds_needed(race, ahead) if evidence else (0, True)
    return Verdict(UNDECIDED, None, ahead, seeds, needed, within, detectable, reason)


def seeds_needed(race: UnitRace, ahead: list[Racer]) -> tuple[int, bool]:
    """Paired seeds that give 80% power at the leading contender's gain and discordance:
    on this race's plan when its looks reach that power (a rerun on the same ``--out``
    continues to them: True), else the size of a new plan (a new test: False)."""
    if not ahead:
        return 0, True
    current = race.current
    best = max(ahead, key=lambda r: (gain(r, current), -r.rank))
    n = max(1, min(len(best.outcomes), len(current.outcomes)))
    won, lost = discordant(best.outcomes, current.outcomes)
    delta, psi = (won - lost) / n, max((won + lost) / n, (won - lost) / n)
    look = race.plan.looks_for(delta, psi)
    if look is not None:
        return race.seeds_of(look), True
    fresh = seeds_for_power(
        round(delta, 3), round(psi, 2), race.plan.block, race.alpha / race.plan.challengers
    )
    return fresh, False


def advance(race: UnitRace, block_of: dict[int, list[bool]]) -> None:
    """Give every alive racer its next block of outcomes (keyed by screening rank) and look:
    what the race runner does with episodes, for constructed or simulated outcomes."""
    for racer in race.alive():
        racer.outcomes.extend(block_of[racer.rank])
        racer.reference.extend(block_of[racer.rank])
    update(race)
