"""Weighted draws as an exponential race keyed by the global grasp index.

A weighted draw among candidates with weights ``w`` (the reference's 1/score) can be made by
giving every candidate ``i`` a key ``E_i / w_i`` with ``E_i ~ Exp(1)`` and taking the smallest:
candidate ``i`` wins with probability ``w_i / sum(w)``, exactly the distribution of
``rng.choice(p=w / w.sum())``. Without replacement, the ``k`` smallest keys are a weighted
sample without replacement with the same law as drawing one at a time from what is left
(Efraimidis and Spirakis, 2006).

Here ``E_i`` comes from a counter-based hash of (a key drawn from the episode's candidate
stream, the draw number, the *global* grasp index), not from a sequence. So two filter settings
evaluated on the same seed give every grasp the same key: a grasp that wins a draw under one
setting wins it under every other setting that keeps it and nothing better placed. That coupling
is what lets sweep points that differ only in their filters choose -- and share -- the same
candidates as often as the law of the draw allows (``harness.episode.candidate_cache``).
"""

from __future__ import annotations

import numpy as np

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX_1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX_2 = np.uint64(0x94D049BB133111EB)
_DRAW_STRIDE = np.uint64(0xD6E8FEB86659FD93)


def _splitmix64(x: np.ndarray) -> np.ndarray:
    """SplitMix64's finaliser: a bijective mix of 64-bit integers (wrapping arithmetic)."""
    with np.errstate(over="ignore"):
        z = x + _GOLDEN
        z = (z ^ (z >> np.uint64(30))) * _MIX_1
        z = (z ^ (z >> np.uint64(27))) * _MIX_2
        return z ^ (z >> np.uint64(31))


def race_key(rng: np.random.Generator) -> int:
    """The race's key for one episode, drawn from its candidate stream."""
    return int(rng.integers(0, 2**63, dtype=np.int64))


def exponential_keys(key: int, indices: np.ndarray, draws: int) -> np.ndarray:
    """``E ~ Exp(1)`` of shape (draws, len(indices)), a pure function of (key, draw, index)."""
    index = np.asarray(indices, dtype=np.uint64)[None, :]
    draw = np.arange(draws, dtype=np.uint64)[:, None]
    with np.errstate(over="ignore"):
        mixed = _splitmix64(_splitmix64(np.uint64(key) ^ (draw * _DRAW_STRIDE)) ^ index)
    # 53 random bits -> a uniform in (0, 1]: never 0, so the logarithm is finite.
    uniform = ((mixed >> np.uint64(11)).astype(np.float64) + 1.0) / float(2**53)
    return -np.log(uniform)


def draw_with_replacement(
    key: int, indices: np.ndarray, weights: np.ndarray, draws: int
) -> np.ndarray:
    """``draws`` weighted draws with replacement among ``indices`` (the winner of each race)."""
    race = exponential_keys(key, indices, draws) / np.asarray(weights, dtype=np.float64)[None, :]
    return np.asarray(indices, dtype=np.int64)[np.argmin(race, axis=1)]


def draw_without_replacement(
    key: int, indices: np.ndarray, weights: np.ndarray, count: int
) -> np.ndarray:
    """``count`` weighted draws without replacement among ``indices`` (the smallest keys)."""
    race = exponential_keys(key, indices, 1)[0] / np.asarray(weights, dtype=np.float64)
    order = np.argsort(race, kind="stable")[:count]
    return np.asarray(indices, dtype=np.int64)[order]
