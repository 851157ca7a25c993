"""The tune's decision: a race of the screening's best settings against the current one on fresh
seeds, and its verdict ("keep current", "switch to X" or "undecided within budget").

Pure logic over paired outcomes (no episodes run here; ``harness.tuning.race`` feeds it). One
*unit* is one robot, arm and object; its racers are the current setting and the few best
settings of the screening. Every racer alive in a round runs the round's block of fresh seeds,
so all alive racers share every seed (common random numbers) and each comparison is paired.

After each round (a *look*; at most ``looks`` = ``max_seeds / block`` of them):

- **claims**: each alive challenger c against the current setting, the exact one-sided McNemar
  test (``scipy.stats.binomtest`` of c-only successes among the discordant seeds, p = 1/2,
  alternative "greater"), Holm-corrected over the alive challengers (:func:`holm`, equal to
  statsmodels ``multipletests(method="holm")``) at level ``alpha / looks``. Bonferroni over
  the looks makes the claims valid whatever the race stops on: the chance of any false
  "better than current" over the whole race is at most ``alpha`` (Holm 1979; the union bound).
  A challenger rejected at a look is *confirmed* (it stays confirmed).
- **elimination**: the leader (most successes; ties: the current, then confirmed, then screening
  order) against each other alive challenger, the same test and correction; a challenger the
  leader beats is dropped (Maron & Moore's Hoeffding races / Birattari's F-race: drop what is
  shown worse than the best, spend seeds on the rest). A racer that fell back to the
  reference's unfiltered rows (its filter kept nothing) is dropped at once: never recommended.
  The current setting is never dropped: it is the control every claim is paired with.

The race of a unit stops when no challenger is alive, when no alive challenger is ahead of the
current setting after ``min_looks`` looks (ties keep the current), when exactly one challenger
is alive and confirmed, or at ``looks`` rounds / the budget. Verdict: a confirmed challenger
-> "switch" (the confirmed one with the largest paired gain); else an alive challenger ahead
of current -> "undecided within budget"
(with the seeds a paired test would need to settle it); else "keep current".
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.stats import binomtest, norm

KEEP = "keep current"
SWITCH = "switch"
UNDECIDED = "undecided within budget"
POWER = 0.8


@dataclass
class Racer:
    """One setting in a unit's race: its outcomes on the race seeds so far."""

    setting: tuple[str, str]
    rank: int  # screening order (0 = the current setting)
    outcomes: list[bool] = field(default_factory=list)
    reference: list[bool] = field(default_factory=list)  # the reference success, beside it
    alive: bool = True
    fallback: bool = False
    confirmed_at: int | None = None  # the look that confirmed it better than current
    dropped_at: int | None = None
    p_value: float = math.nan  # Holm-adjusted claim p-value at the look that confirmed it

    @property
    def successes(self) -> int:
        return int(sum(self.outcomes))


@dataclass
class UnitRace:
    """The race of one unit: ``racers[0]`` is the current setting."""

    racers: list[Racer]
    looks: int
    alpha: float = 0.05
    min_looks: int = 2  # looks before "no challenger ahead" may stop the race (chosen)
    look: int = 0
    stopped: str = ""  # why the race of this unit stopped ("" while it runs)

    @property
    def current(self) -> Racer:
        return self.racers[0]

    def alive(self) -> list[Racer]:
        """The racers that run the next block (the current setting always)."""
        return [r for r in self.racers if r.alive]

    def challengers(self) -> list[Racer]:
        return [r for r in self.racers[1:] if r.alive]


def discordant(a: list[bool], b: list[bool]) -> tuple[int, int]:
    """(a-only, b-only) successes over the seeds both ran (the first ``min`` outcomes)."""
    n = min(len(a), len(b))
    x, y = np.asarray(a[:n], bool), np.asarray(b[:n], bool)
    return int((x & ~y).sum()), int((y & ~x).sum())


def one_sided_mcnemar(better_only: int, worse_only: int) -> float:
    """Exact one-sided McNemar p-value that the first is better (1 without discordant seeds)."""
    total = better_only + worse_only
    if total == 0:
        return 1.0
    return float(binomtest(better_only, total, 0.5, alternative="greater").pvalue)


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
    """Most successes among the alive; ties: the current, then confirmed, then screening rank."""
    return max(
        race.alive(),
        key=lambda r: (r.successes, r is race.current, r.confirmed_at is not None, -r.rank),
    )


def update(race: UnitRace) -> None:
    """Apply one look to a unit whose alive racers all hold the same number of outcomes."""
    race.look += 1
    level = race.alpha / race.looks
    for racer in race.challengers():
        if racer.fallback:
            racer.alive, racer.dropped_at = False, race.look
    challengers = race.challengers()
    claims = [
        one_sided_mcnemar(*discordant(r.outcomes, race.current.outcomes)) for r in challengers
    ]
    for racer, rejected, adjusted in zip(challengers, *holm(claims, level), strict=True):
        if rejected and racer.confirmed_at is None:
            racer.confirmed_at, racer.p_value = race.look, adjusted
    best = leader(race)
    others = [r for r in race.challengers() if r is not best]
    beaten = [one_sided_mcnemar(*discordant(best.outcomes, r.outcomes)) for r in others]
    for racer, rejected in zip(others, holm(beaten, level)[0], strict=True):
        if rejected:
            racer.alive, racer.dropped_at = False, race.look
    race.stopped = stop_reason(race)


def gain(racer: Racer, current: Racer) -> int:
    """Seeds won minus seeds lost against the current setting (paired)."""
    won, lost = discordant(racer.outcomes, current.outcomes)
    return won - lost


def stop_reason(race: UnitRace) -> str:
    """Why the unit's race stops after this look, or "" to go on."""
    challengers = race.challengers()
    if not challengers:
        return "every challenger dropped"
    if race.look >= race.min_looks and all(gain(r, race.current) <= 0 for r in challengers):
        return "no challenger ahead of the current setting"
    if len(challengers) == 1 and challengers[0].confirmed_at is not None:
        return "one confirmed challenger left"
    if race.look >= race.looks:
        return "all looks spent"
    return ""


@dataclass(frozen=True)
class Verdict:
    """A unit's decision and its evidence (rates on the race's fresh seeds)."""

    verdict: str
    chosen: Racer | None  # the setting to switch to (None: keep / undecided)
    contenders: list[Racer]  # undecided: the challengers still ahead of current
    seeds: int  # fresh seeds the current setting ran
    seeds_needed: int  # undecided: paired seeds that would give 80% power at the gain seen
    reason: str


def verdict(race: UnitRace, why: str = "") -> Verdict:
    """The decision of a stopped (or budget-stopped) unit race."""
    current = race.current
    seeds = len(current.outcomes)
    confirmed = [r for r in race.racers[1:] if r.confirmed_at is not None and not r.fallback]
    reason = race.stopped or why
    if confirmed:
        best = max(confirmed, key=lambda r: (gain(r, current), -r.rank))
        return Verdict(SWITCH, best, [], seeds, 0, reason)
    ahead = [r for r in race.challengers() if gain(r, current) > 0 and not r.fallback]
    if ahead:
        needed = max(seeds_needed(r, current, race.alpha / race.looks) for r in ahead)
        return Verdict(UNDECIDED, None, ahead, seeds, needed, reason)
    return Verdict(KEEP, None, [], seeds, 0, reason)


def seeds_needed(racer: Racer, current: Racer, level: float) -> int:
    """Paired seeds for 80% power of a one-sided McNemar test at ``level``, at the gain and
    discordance seen (Connor 1987's normal approximation; scipy's normal quantiles)."""
    n = max(1, min(len(racer.outcomes), len(current.outcomes)))
    won, lost = discordant(racer.outcomes, current.outcomes)
    delta, psi = (won - lost) / n, (won + lost) / n
    if delta <= 0:
        return 0
    z_a, z_b = norm.ppf(1 - level), norm.ppf(POWER)
    root = z_a * math.sqrt(psi) + z_b * math.sqrt(max(psi - delta * delta, 0.0))
    return math.ceil(root * root / (delta * delta))


def gain_interval(racer: Racer, current: Racer, confidence: float = 0.95) -> tuple[float, float]:
    """Interval of the paired gain (rate difference), conditional on the discordant seeds:
    gain = d/n (2 pi - 1) with pi the Clopper-Pearson interval of won/d (``binomtest``)."""
    n = min(len(racer.outcomes), len(current.outcomes))
    won, lost = discordant(racer.outcomes, current.outcomes)
    if won + lost == 0 or n == 0:
        return 0.0, 0.0
    ci = binomtest(won, won + lost).proportion_ci(confidence, method="exact")
    scale = (won + lost) / n
    return scale * (2 * ci.low - 1), scale * (2 * ci.high - 1)


def advance(race: UnitRace, block_of: dict[int, list[bool]]) -> None:
    """Give every alive racer its next block of outcomes (keyed by screening rank) and look:
    what the race runner does with episodes, for constructed or simulated outcomes."""
    for racer in race.alive():
        racer.outcomes.extend(block_of[racer.rank])
        racer.reference.extend(block_of[racer.rank])
    update(race)
