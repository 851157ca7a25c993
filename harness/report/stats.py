"""Binomial statistics for success rates: Wilson intervals, two-proportion and McNemar tests.

Success rates in a sweep come from small samples (tens of episodes per point), where the normal
approximation interval is poor; the Wilson score interval stays inside [0, 1] and keeps close to
its nominal coverage. Two rates are compared with the pooled two-proportion z-test, or with
Fisher's exact test when an expected cell count is below 5 and the z-test's approximation fails.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Literal

# scipy.stats (~0.5 s to import) is imported only by the comparisons (z, Fisher, McNemar): a
# report's Wilson intervals are the few lines of scipy's ``_binom_wilson_conf_int`` below.

# Below this expected count in any cell of the 2x2 table, the z-test is replaced by Fisher's.
MIN_EXPECTED_COUNT = 5.0
# ``scipy.special.ndtri(0.975)``: the two-sided 95% quantile that binomtest's Wilson interval uses
# (tests/test_report.py checks it and every interval up to n = 100 against scipy).
Z_95 = 1.959963984540054


@functools.lru_cache(maxsize=64)
def _z_for(confidence: float) -> float:
    """The two-sided normal quantile of ``confidence``, as scipy's Wilson interval computes it."""
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence}")
    if confidence == 0.95:
        return Z_95
    from scipy.special import ndtri

    return float(ndtri(0.5 + 0.5 * confidence))


def _check_counts(successes: int, n: int) -> None:
    if n < 0 or successes < 0 or successes > n:
        raise ValueError(f"need 0 <= successes <= n, got {successes}/{n}")


def wilson_interval(successes: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of ``successes / n`` (scipy's ``binomtest(...).proportion_ci``,
    method ``wilson``); ``(0, 1)`` when there are no trials."""
    _check_counts(successes, n)
    _z_for(confidence)  # the same ValueError for a confidence outside (0, 1)
    if n == 0:
        return 0.0, 1.0
    return _wilson(int(successes), int(n), float(confidence))


@functools.lru_cache(maxsize=4096)
def _wilson(successes: int, n: int, confidence: float) -> tuple[float, float]:
    """``wilson_interval`` of checked counts, kept per (k, n, confidence): a report of a dense
    grid asks for the same few small counts thousands of times. The arithmetic of scipy's
    ``binomtest(k, n).proportion_ci(method="wilson")`` (``_binom_wilson_conf_int``), in its order,
    so the floats are the same."""
    z = _z_for(confidence)
    p = successes / n
    denom = 2 * (n + z**2)
    center = (2 * n * p + z**2) / denom
    delta = z / denom * math.sqrt(4 * n * p * (1 - p) + z**2)
    # Exact 0 and 1 at the extremes (rounding would leave 1e-17 instead).
    low = 0.0 if successes == 0 else max(0.0, center - delta)
    high = 1.0 if successes == n else min(1.0, center + delta)
    return low, high


def two_proportion_z_test(k1: int, n1: int, k2: int, n2: int) -> tuple[float, float]:
    """Pooled two-proportion z-test of ``k1/n1`` vs ``k2/n2``: ``(z, two-sided p)``.

    ``z`` is positive when the second rate is higher. Identical all-or-nothing samples (pooled
    rate 0 or 1) give ``(0, 1)``; an empty sample gives ``(nan, nan)``.
    """
    _check_counts(k1, n1)
    _check_counts(k2, n2)
    if n1 == 0 or n2 == 0:
        return math.nan, math.nan
    pooled = (k1 + k2) / (n1 + n2)
    variance = pooled * (1.0 - pooled) * (1.0 / n1 + 1.0 / n2)
    if variance == 0.0:
        return 0.0, 1.0
    z = (k2 / n2 - k1 / n1) / math.sqrt(variance)
    from scipy import stats as scipy_stats

    return z, float(2.0 * scipy_stats.norm.sf(abs(z)))


def fisher_exact_p(k1: int, n1: int, k2: int, n2: int) -> float:
    """Two-sided Fisher exact test p-value of the 2x2 table successes/failures x samples."""
    _check_counts(k1, n1)
    _check_counts(k2, n2)
    if n1 == 0 or n2 == 0:
        return math.nan
    from scipy import stats as scipy_stats

    table = [[k1, n1 - k1], [k2, n2 - k2]]
    result = scipy_stats.fisher_exact(table, alternative="two-sided")
    # scipy's decorator hides the result type (a SignificanceResult with .pvalue).
    return float(result.pvalue)  # pyright: ignore[reportAttributeAccessIssue]


@dataclass(frozen=True)
class Comparison:
    """Rate difference ``rate2 - rate1`` with the p-value of the test that suits the counts."""

    rate1: float
    rate2: float
    difference: float
    z: float
    p_value: float
    test: Literal["z", "fisher", ""]


def compare_proportions(k1: int, n1: int, k2: int, n2: int) -> Comparison:
    """Compare two success rates: the z-test, or Fisher's exact test for small expected counts."""
    z, p_z = two_proportion_z_test(k1, n1, k2, n2)
    if n1 == 0 or n2 == 0:
        rate1 = k1 / n1 if n1 else math.nan
        rate2 = k2 / n2 if n2 else math.nan
        return Comparison(rate1, rate2, rate2 - rate1, math.nan, math.nan, "")
    rate1, rate2 = k1 / n1, k2 / n2
    total = n1 + n2
    successes, failures = k1 + k2, total - k1 - k2
    expected = [n * c / total for n in (n1, n2) for c in (successes, failures)]
    if min(expected) < MIN_EXPECTED_COUNT:
        return Comparison(rate1, rate2, rate2 - rate1, z, fisher_exact_p(k1, n1, k2, n2), "fisher")
    return Comparison(rate1, rate2, rate2 - rate1, z, p_z, "z")


@dataclass(frozen=True)
class McNemar:
    """Exact McNemar test of two paired success records (same seeds, two settings).

    ``only_a`` pairs succeed under A alone, ``only_b`` under B alone; the concordant pairs carry
    no information about the difference. The two-sided p-value is the exact binomial test of
    ``only_b`` out of the ``only_a + only_b`` discordant pairs against 1/2 (1 when there are none).
    """

    only_a: int
    only_b: int
    p_value: float

    @property
    def discordant(self) -> int:
        return self.only_a + self.only_b


def mcnemar_exact(only_a: int, only_b: int) -> McNemar:
    """The exact McNemar test from the discordant pair counts (see :class:`McNemar`)."""
    if only_a < 0 or only_b < 0:
        raise ValueError(f"discordant counts must be >= 0, got {only_a}, {only_b}")
    total = only_a + only_b
    if total == 0:
        return McNemar(only_a, only_b, 1.0)
    from scipy import stats as scipy_stats

    result = scipy_stats.binomtest(only_b, total, 0.5, alternative="two-sided")
    return McNemar(only_a, only_b, min(1.0, float(result.pvalue)))
