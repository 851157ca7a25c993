"""Episode ids and seeds: the two deterministic names of an episode.

A leaf module (NumPy only) so that the episode, its row and the sweep can all name episodes
without importing each other.

The episode seed depends only on (sweep seed, episode index), so episode k of every point sees
the same object placement and home noise -- points are compared on common random numbers. The
episode id hashes (task, point, episode index), so resuming a sweep runs exactly what is missing.
"""

from __future__ import annotations

import hashlib
import json
from typing import Any

import numpy as np


def episode_seed(sweep_seed: int, episode_index: int) -> int:
    """Seed of episode ``episode_index``; independent of task and point (common random numbers)."""
    sequence = np.random.SeedSequence([int(sweep_seed), int(episode_index)])
    return int(sequence.generate_state(1, dtype=np.uint64)[0] & ((1 << 63) - 1))


def episode_id(task_name: str, point: dict[str, Any], episode_index: int) -> str:
    """Deterministic id from the task, the point's parameter values and the episode index."""
    key = json.dumps([task_name, point, episode_index], sort_keys=True, default=str)
    digest = hashlib.sha1(key.encode()).hexdigest()[:10]
    return f"{task_name}-e{episode_index:04d}-{digest}"
