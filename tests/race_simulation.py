"""The race's error and power on simulated settings: ``python tests/race_simulation.py``.

Each seed draws every setting's outcome from one Gaussian copula: setting k succeeds when
``sqrt(r) Z + sqrt(1 - r) E_k < Phi^-1(p_k)`` (Z shared by the seed, E_k its own), so settings
are positively correlated on a seed as the grid's are (the issue measured rho ~ 0.45 between
settings on a seed); the race is the tune's own code (``harness.tuning.decide``). Prints the
false "switch" rate when no challenger is better (all at the current rate), and the switch rate
when one challenger is better by each gain.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np
from scipy.stats import norm

from harness.tuning.decide import (
    FLOOR,
    KEEP,
    NO_SETTING_HELPS,
    SWITCH,
    UNDECIDED,
    Racer,
    UnitRace,
    advance,
    futility_bound,
    one_sided_mcnemar,
    verdict,
)
from harness.tuning.intervals import exact_interval
from harness.tuning.sequential import Plan


def draw(rates: list[float], seeds: int, latent: float, rng: np.random.Generator) -> np.ndarray:
    """(settings, seeds) outcomes from the Gaussian copula with latent correlation ``latent``."""
    shared = rng.standard_normal(seeds)
    own = rng.standard_normal((len(rates), seeds))
    z = np.sqrt(latent) * shared + np.sqrt(1.0 - latent) * own
    return z < norm.ppf(np.asarray(rates))[:, None]


def bernoulli_correlation(rate: float, latent: float, rng: np.random.Generator) -> float:
    """The outcome correlation of two settings at ``rate`` (estimated on 200k seeds)."""
    pair = draw([rate, rate], 200_000, latent, rng)
    return float(np.corrcoef(pair[0], pair[1])[0, 1])


def one_race(
    rates: list[float],
    block: int,
    max_seeds: int,
    latent: float,
    rng: np.random.Generator,
    alpha: float = 0.05,
) -> tuple[str, int, int]:
    """(verdict, chosen rank or -1, seeds used) of one race; rates[0] is the current setting."""
    outcomes = draw(rates, max_seeds, latent, rng)
    racers = [Racer(("a", str(k)), k) for k in range(len(rates))]
    plan = Plan(max_seeds, block, alpha, challengers=len(rates) - 1)
    race = UnitRace(racers, plan)
    while not race.stopped:
        start = race.look * block
        advance(race, {k: list(outcomes[k, start : start + block]) for k in range(len(rates))})
    decided = verdict(race, evidence=False)
    chosen = decided.chosen.rank if decided.chosen else -1
    return decided.verdict, chosen, decided.seeds


def switch_rate(
    rates: list[float], runs: int, block: int, max_seeds: int, latent: float, seed: int
) -> tuple[float, float, float]:
    """(share of runs that switch, that switch to rank 1, mean fresh seeds used)."""
    rng = np.random.default_rng(seed)
    results = [one_race(rates, block, max_seeds, latent, rng) for _ in range(runs)]
    switched = np.mean([v == SWITCH for v, _, _ in results])
    to_best = np.mean([v == SWITCH and c == 1 for v, c, _ in results])
    return float(switched), float(to_best), float(np.mean([s for _, _, s in results]))


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    p.add_argument("--runs", type=int, default=2000)
    p.add_argument("--rate", type=float, default=0.8, help="the current setting's rate")
    p.add_argument("--latent", type=float, default=0.62, help="copula correlation")
    p.add_argument("--block", type=int, default=10)
    p.add_argument("--max-seeds", type=int, default=40)
    p.add_argument("--top", type=int, default=3)
    p.add_argument("--gains", default="0.05,0.1,0.15,0.2")
    args = p.parse_args(argv)
    rho = bernoulli_correlation(args.rate, args.latent, np.random.default_rng(1))
    print(
        f"current rate {args.rate}, outcome correlation between settings {rho:.2f}, "
        f"{args.top} challengers, blocks of {args.block} up to {args.max_seeds}, "
        f"{args.runs} races each"
    )
    null = [args.rate] * (args.top + 1)
    rate, _, seeds = switch_rate(null, args.runs, args.block, args.max_seeds, args.latent, 2)
    print(f"no challenger better: switch in {rate:.1%} of races (mean {seeds:.0f} seeds)")
    for gain in (float(g) for g in args.gains.split(",")):
        rates = [args.rate, min(args.rate + gain, 1.0), *[args.rate] * (args.top - 1)]
        rate, best, seeds = switch_rate(
            rates, args.runs, args.block, args.max_seeds, args.latent, 3
        )
        print(
            f"one challenger +{gain:.2f}: switch in {rate:.1%}, to it in {best:.1%} "
            f"(mean {seeds:.0f} seeds)"
        )


if __name__ == "__main__":
    main()


@dataclass(frozen=True)
class VectorRaces:
    """Many one-challenger races at once (``vector_races``): per race the look it stopped at,
    its verdict and the paired table (both, new only, current only, neither) at that look."""

    look: np.ndarray
    verdict: np.ndarray  # of VERDICTS' strings
    table: np.ndarray  # (runs, 4)


def vector_races(
    current_rate: float,
    new_rate: float,
    plan: Plan,
    runs: int,
    latent: float,
    rng: np.random.Generator,
    outcomes: np.ndarray | None = None,
) -> VectorRaces:
    """The race of the current setting and one challenger (``harness.tuning.decide``'s rules
    with one challenger: claim, elimination by the current, the floor, the ruled-out gain, the
    plan's end), on ``runs`` copula-drawn races at once with the race's own functions
    (``Plan.level``, ``one_sided_mcnemar``, ``paired_gain_interval``, ``exact_interval``).
    ``outcomes`` (runs, 2, seeds) replaces the draw (tests compare with the scalar race)."""
    if outcomes is None:
        outcomes = np.stack(
            [draw([current_rate, new_rate], plan.seeds, latent, rng) for _ in range(runs)]
        )
    now, new = outcomes[:, 0, :], outcomes[:, 1, :]
    running = np.ones(runs, bool)
    look = np.zeros(runs, int)
    verdicts = np.full(runs, UNDECIDED, dtype=object)
    final = np.zeros((runs, 4), int)
    for k in range(1, plan.looks + 1):
        n = min(k * plan.block, plan.seeds)
        a = (new[:, :n] & now[:, :n]).sum(1)
        b = (new[:, :n] & ~now[:, :n]).sum(1)
        c = (~new[:, :n] & now[:, :n]).sum(1)
        d = n - a - b - c
        level = plan.level(k, 1)
        confirmed = one_sided_mcnemar(b, c) <= level
        dropped = ~confirmed & (a + c >= a + b) & (one_sided_mcnemar(c, b) <= level)
        hi_now = exact_interval(a + c, n)[1]
        hi_new = exact_interval(a + b, n)[1]
        floor = ~confirmed & (hi_now < FLOOR) & (dropped | (hi_new < FLOOR))
        ruled = ~confirmed & ~dropped & ~floor
        ruled &= futility_bound(b, c, a, d, level) < plan.target_gain
        end = k == plan.looks
        decided = {
            SWITCH: confirmed,
            NO_SETTING_HELPS: floor,
            KEEP: (dropped & ~floor) | ruled | (end & ~confirmed & ~floor & ~dropped & (b <= c)),
            UNDECIDED: end & ~confirmed & ~floor & ~dropped & ~ruled & (b > c),
        }
        for name, mask in decided.items():
            stop = running & mask
            verdicts[stop], look[stop] = name, k
            final[stop] = np.stack([a, b, c, d], 1)[stop]
            running &= ~stop
    return VectorRaces(look, verdicts, final)
