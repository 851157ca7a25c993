"""The race's group-sequential design: when a look may claim a gain, and how many seeds a race
needs for the power to see one.

A unit's race is planned once, before its first look, as ``seeds`` fresh seeds per racer in
looks of ``block`` (the last look at ``seeds``): look k sits at information time
``t_k = k block / seeds``. The one-sided type-I error ``alpha`` is spent over the looks by
Lan & DeMets' Pocock-type spending function ``alpha ln(1 + (e - 1) t)`` (Lan & DeMets 1983,
Biometrika 70:659), which spends evenly enough that a race capped early (``--budget``) still has
most of its levels, and stops a clear gain early. The boundaries are the exact group-sequential
ones for the Brownian motion of the paired (McNemar) z-statistic, computed by the recursive
numerical integration of Armitage, McPherson & Rowe (1969) on a grid (Jennison & Turnbull 2000,
ch. 19): the chance that any look crosses, with nothing better, is the spent alpha, not the
Bonferroni bound's. Each boundary is used as a nominal one-sided level for the exact McNemar
test at its look (the nominal-significance form of a group-sequential test).

Because the levels depend only on the plan (``seeds``, ``block``, ``alpha``), a race continued
on the same ``--out`` replays its stored looks at the same levels and goes on with the next ones:
it is one test, whose alpha is spent once. Past the plan's last look nothing is left to spend.

Power and sizes use the normal approximation of the McNemar statistic: with a paired gain
``delta`` and discordance ``psi`` (the share of seeds where the two settings disagree), the
z-statistic after n seeds has mean ``sqrt(n) delta / sqrt(psi)``.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import cast

import numpy as np
from scipy.optimize import brentq
from scipy.special import ndtr

GRID = 241  # points of the integration grid per look (odd: Simpson's rule)
SPAN = 8.0  # the grid reaches SPAN standard deviations below the mean
POWER = 0.8
MAX_SEEDS = 20_000  # the largest race a plan proposes (chosen, no public source)
MAX_LOOKS = 50  # a plan's looks at most; a longer plan looks every seeds / 50 (chosen: the levels
# of 50 looks are within a few percent of continuous monitoring's; more looks only cost alpha)
SQRT_2PI = math.sqrt(2.0 * math.pi)


def _sf(z: np.ndarray | float) -> np.ndarray:
    return ndtr(-np.asarray(z, float))


def _pdf(z: np.ndarray) -> np.ndarray:
    return np.exp(-0.5 * z * z) / SQRT_2PI


def plan_block(seeds: int, block: int, max_looks: int = MAX_LOOKS) -> int:
    """The look spacing of a plan: ``block``, or ``seeds / max_looks`` rounded up when larger."""
    return max(block, math.ceil(seeds / max_looks))


def spent(t: float, alpha: float) -> float:
    """Alpha spent by information time ``t`` (Lan-DeMets Pocock-type; all of it at t >= 1)."""
    return alpha * math.log1p((math.e - 1.0) * min(max(t, 0.0), 1.0))


def look_times(seeds: int, block: int) -> list[float]:
    """Information times of the looks of a plan of ``seeds`` in blocks of ``block``."""
    looks = max(1, math.ceil(seeds / block))
    return [min(k * block, seeds) / seeds for k in range(1, looks + 1)]


def _simpson(count: int) -> np.ndarray:
    weights = np.ones(count)
    weights[1:-1:2], weights[2:-1:2] = 4.0, 2.0
    return weights / 3.0


def _crossings(
    times: list[float], bounds: list[float] | None, alpha: float, drift: float
) -> tuple[list[float], list[float]]:
    """(boundaries on the B = Z sqrt(t) scale, crossing probability at each look).

    ``bounds`` None: solve each boundary so that the crossing chance under no drift is the
    look's alpha increment. Else use the given boundaries and return the crossing chances
    under ``drift`` (B(t) ~ N(drift t, t)).
    """
    solved: list[float] = []
    cross: list[float] = []
    x = w = f = np.empty(0)
    previous = 0.0
    for k, t in enumerate(times):
        step = t - previous
        sd = math.sqrt(step)

        def tail(b: float, k=k, t=t, x=x, w=w, f=f, sd=sd, step=step) -> float:
            """Chance of crossing ``b`` at this look (and not before)."""
            if k == 0:
                return float(_sf((b - drift * t) / math.sqrt(t)))
            return float(np.dot(w * f, _sf((b - x - drift * step) / sd)))

        if bounds is None:
            target = spent(t, alpha) - spent(previous, alpha)
            if target <= 1e-12:
                b = math.inf
            else:
                low = -SPAN * math.sqrt(t) - 1.0
                b = float(
                    cast(
                        float,
                        brentq(
                            lambda b, goal=target: tail(b) - goal,
                            low,
                            SPAN * math.sqrt(t) + 10.0,
                            xtol=1e-6,
                        ),
                    )
                )
            solved.append(b)
        else:
            b = bounds[k]
        cross.append(0.0 if math.isinf(b) else tail(b))
        top = min(b, drift * t + SPAN * math.sqrt(t))
        bottom = drift * t - SPAN * math.sqrt(t)
        y = np.linspace(bottom, max(top, bottom + 1e-6), GRID)
        if k == 0:
            g = _pdf((y - drift * t) / math.sqrt(t)) / math.sqrt(t)
        else:
            kernel = _pdf((y[:, None] - x[None, :] - drift * step) / sd) / sd
            g = kernel @ (w * f)
        x, f = y, g
        w = _simpson(GRID) * (y[1] - y[0])
        previous = t
    return (solved if bounds is None else bounds), cross


@functools.lru_cache(maxsize=256)
def boundaries(seeds: int, block: int, alpha: float) -> tuple[float, ...]:
    """The plan's boundaries on the B scale (one per look; inf where nothing is spent)."""
    return tuple(_crossings(look_times(seeds, block), None, alpha, 0.0)[0])


@functools.lru_cache(maxsize=256)
def nominal_levels(seeds: int, block: int, alpha: float) -> tuple[float, ...]:
    """One-sided nominal level of each look: the exact test at look k claims when its p-value
    is at most ``levels[k - 1]``."""
    times = look_times(seeds, block)
    return tuple(
        float(_sf(b / math.sqrt(t)))
        for b, t in zip(boundaries(seeds, block, alpha), times, strict=True)
    )


def power(
    seeds: int, block: int, alpha: float, gain: float, discordance: float, looks: int | None = None
) -> float:
    """Chance that the race of this plan confirms a challenger better by ``gain`` (paired
    discordance ``discordance``) by look ``looks`` (default: the plan's last)."""
    if gain <= 0.0:
        return 0.0
    psi = max(discordance, gain)
    drift = math.sqrt(seeds) * gain / math.sqrt(psi)
    times = look_times(seeds, block)
    bounds = list(boundaries(seeds, block, alpha))
    count = len(times) if looks is None else max(0, min(looks, len(times)))
    if count == 0:
        return 0.0
    return float(sum(_crossings(times[:count], bounds[:count], alpha, drift)[1]))


@functools.lru_cache(maxsize=512)
def seeds_for_power(
    gain: float,
    discordance: float,
    block: int,
    alpha: float,
    target: float = POWER,
    max_looks: int = MAX_LOOKS,
) -> int:
    """The smallest plan (a multiple of ``block``, looks every :func:`plan_block` at most
    ``max_looks`` times) whose race has ``target`` power for ``gain`` (``MAX_SEEDS`` rounded up
    to a block when even that is not enough)."""

    def enough(blocks: int) -> bool:
        seeds = blocks * block
        spacing = plan_block(seeds, block, max_looks)
        return power(seeds, spacing, alpha, gain, discordance) >= target

    top = math.ceil(MAX_SEEDS / block)
    if not enough(top):
        return top * block
    low, high = 1, top
    while low < high:
        mid = (low + high) // 2
        if enough(mid):
            high = mid
        else:
            low = mid + 1
    return low * block


@functools.lru_cache(maxsize=1024)
def detectable_gain(
    seeds: int, block: int, alpha: float, discordance: float, looks: int, target: float = POWER
) -> float:
    """The smallest gain the plan's first ``looks`` looks confirm with ``target`` power."""
    if looks <= 0:
        return math.inf
    if power(seeds, block, alpha, 1.0, discordance, looks) < target:
        return math.inf
    root = brentq(
        lambda g: power(seeds, block, alpha, g, discordance, looks) - target, 1e-4, 1.0, xtol=1e-4
    )
    return float(cast(float, root))


@functools.lru_cache(maxsize=1024)
def looks_for_power(
    seeds: int, block: int, alpha: float, gain: float, discordance: float, target: float = POWER
) -> int | None:
    """The first look of the plan by which the race has ``target`` power at ``gain``; None
    when even the plan's last look has less."""
    times = look_times(seeds, block)
    for k in range(1, len(times) + 1):
        if power(seeds, block, alpha, gain, discordance, k) >= target:
            return k
    return None


def correlated_discordance(rate: float, gain: float, correlation: float) -> float:
    """Share of seeds on which settings at ``rate`` and ``rate + gain`` disagree when their
    outcomes correlate by ``correlation`` (Pearson, on a seed)."""
    p, q = rate, min(rate + gain, 1.0)
    both = p * q + correlation * math.sqrt(p * (1 - p) * q * (1 - q))
    return max(p + q - 2 * both, gain)


@dataclass(frozen=True)
class Plan:
    """One unit's race plan: ``seeds`` fresh seeds per racer at most, looks of ``block``, the
    one-sided ``alpha`` of its claims, spent over ``challengers`` (Holm), and the gain and
    discordance it was sized for."""

    seeds: int
    block: int
    alpha: float = 0.05
    challengers: int = 1
    target_gain: float = 0.05
    discordance: float = 0.3

    @property
    def looks(self) -> int:
        return len(look_times(self.seeds, self.block))

    def level(self, look: int, share: int = 1) -> float:
        """The nominal one-sided level of ``look`` (1-based) with alpha / ``share`` (Holm)."""
        if look < 1 or look > self.looks:
            return 0.0
        return nominal_levels(self.seeds, self.block, self.alpha / share)[look - 1]

    def detectable(self, looks: int, discordance: float | None = None) -> float:
        """The gain the first ``looks`` looks see with 80% power (Bonferroni over the
        challengers: the worst case of Holm's first step)."""
        psi = self.discordance if discordance is None else discordance
        return detectable_gain(self.seeds, self.block, self.alpha / self.challengers, psi, looks)

    def power_at(self, gain: float, discordance: float, looks: int | None = None) -> float:
        return power(
            self.seeds, self.block, self.alpha / self.challengers, gain, discordance, looks
        )

    def looks_for(self, gain: float, discordance: float) -> int | None:
        """The first look with 80% power at ``gain`` (None: not within the plan)."""
        return looks_for_power(
            self.seeds, self.block, self.alpha / self.challengers, gain, discordance
        )
