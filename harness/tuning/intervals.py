"""Confidence intervals of the race's evidence: a rate (Wilson) and a paired gain (Newcombe).

The gain of a challenger over the current setting is a difference of two proportions measured
on the same seeds. Its interval is Newcombe's method 10 for paired data (Newcombe 1998, "Improved
confidence intervals for the difference between binomial proportions based on paired data",
Statistics in Medicine 17:2635): the two rates' Wilson intervals combined with the phi
correlation of the 2x2 table. Unlike an interval conditional on the discordant seeds, it does
not treat their number as known, so it covers when the gain is large (issue 35: the conditional
interval covered 42-67% of a nominal 95%). Coverage is checked by simulation in
``tests/test_tune_sequential.py``. Both functions take numpy arrays, so a simulation computes
thousands of intervals at once.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy.special import ndtri

ArrayOrFloat = np.ndarray | float


def wilson(
    successes: ArrayOrFloat, n: ArrayOrFloat, confidence: float = 0.95
) -> tuple[np.ndarray, np.ndarray]:
    """Wilson score interval (lo, hi) of successes / n; (0, 1) where n is 0."""
    z = float(ndtri(0.5 + 0.5 * confidence))
    k, m = np.asarray(successes, float), np.asarray(n, float)
    safe = np.where(m > 0, m, 1.0)
    p = k / safe
    centre = (p + z * z / (2 * safe)) / (1 + z * z / safe)
    half = z / (1 + z * z / safe) * np.sqrt(p * (1 - p) / safe + z * z / (4 * safe * safe))
    lo = np.where(m > 0, np.clip(centre - half, 0.0, 1.0), 0.0)
    hi = np.where(m > 0, np.clip(centre + half, 0.0, 1.0), 1.0)
    return lo, hi


def paired_gain_interval(
    both: ArrayOrFloat,
    new_only: ArrayOrFloat,
    current_only: ArrayOrFloat,
    neither: ArrayOrFloat,
    confidence: float = 0.95,
) -> tuple[np.ndarray, np.ndarray]:
    """Newcombe's method 10 interval (lo, hi) of p_new - p_current from the paired 2x2 table:
    ``both`` seeds where both succeed, ``new_only``, ``current_only``, ``neither``."""
    a, b, c, d = (np.asarray(v, float) for v in (both, new_only, current_only, neither))
    n = a + b + c + d
    safe = np.where(n > 0, n, 1.0)
    p1, p2 = (a + b) / safe, (a + c) / safe
    l1, u1 = wilson(a + b, n, confidence)
    l2, u2 = wilson(a + c, n, confidence)
    margins = (a + b) * (c + d) * (a + c) * (b + d)
    phi = np.where(margins > 0, (a * d - b * c) / np.sqrt(np.where(margins > 0, margins, 1.0)), 0.0)
    gain = p1 - p2
    dl1, du1, dl2, du2 = p1 - l1, u1 - p1, p2 - l2, u2 - p2
    low = gain - np.sqrt(np.maximum(dl1**2 - 2 * phi * dl1 * du2 + du2**2, 0.0))
    high = gain + np.sqrt(np.maximum(du1**2 - 2 * phi * du1 * dl2 + dl2**2, 0.0))
    return np.where(n > 0, low, -1.0), np.where(n > 0, high, 1.0)


def table(new: list[bool], current: list[bool]) -> tuple[int, int, int, int]:
    """(both, new only, current only, neither) over the seeds both ran."""
    counts = [0, 0, 0, 0]
    for x, y in zip(new, current, strict=False):
        counts[(0 if x else 2) + (0 if y else 1) if x or y else 3] += 1
    return counts[0], counts[1], counts[2], counts[3]


def paired_gain_bounds(
    both: int, new_only: int, current_only: int, neither: int, confidence: float = 0.95
) -> tuple[float, float]:
    """:func:`paired_gain_interval` of one table, in scalar arithmetic (the race calls it at
    every look; tests check the two agree)."""
    from harness.report.stats import wilson_interval

    a, b, c, d = both, new_only, current_only, neither
    n = a + b + c + d
    if n == 0:
        return -1.0, 1.0
    p1, p2 = (a + b) / n, (a + c) / n
    l1, u1 = wilson_interval(a + b, n, confidence)
    l2, u2 = wilson_interval(a + c, n, confidence)
    margins = (a + b) * (c + d) * (a + c) * (b + d)
    phi = (a * d - b * c) / math.sqrt(margins) if margins > 0 else 0.0
    dl1, du1, dl2, du2 = p1 - l1, u1 - p1, p2 - l2, u2 - p2
    low = p1 - p2 - math.sqrt(max(dl1**2 - 2 * phi * dl1 * du2 + du2**2, 0.0))
    high = p1 - p2 + math.sqrt(max(du1**2 - 2 * phi * du1 * dl2 + dl2**2, 0.0))
    return low, high


def exact_interval(
    successes: ArrayOrFloat, n: ArrayOrFloat, confidence: float = 0.95
) -> tuple[Any, Any]:
    """Clopper-Pearson interval (lo, hi) of successes / n (``binomtest(...).proportion_ci``
    method "exact"); (0, 1) where n is 0. The decisions quote it for the race's rates: a race
    stops at a look chosen by its data, and the exact interval keeps its coverage there
    (``tests/test_tune_sequential.py``), where Wilson's dips to 0.93."""
    from scipy.special import betaincinv

    k, m = np.asarray(successes, float), np.asarray(n, float)
    tail = 0.5 * (1.0 - confidence)
    lo = np.where(k > 0, betaincinv(np.maximum(k, 1e-9), m - k + 1, tail), 0.0)
    hi = np.where(k < m, betaincinv(k + 1, np.maximum(m - k, 1e-9), 1.0 - tail), 1.0)
    lo, hi = np.where(m > 0, lo, 0.0), np.where(m > 0, hi, 1.0)
    return (float(lo), float(hi)) if lo.ndim == 0 else (lo, hi)
