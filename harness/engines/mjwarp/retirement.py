"""When worlds leave a batch's lockstep motion: its segments (``motion`` steps them).

Pure arithmetic on the worlds' spans (control steps each must be stepped: its schedule, then
its validity window), so that the plan is tested without a device.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# The share of a segment's worlds whose spans end it; 0: lockstep (one segment), the default.
# Measured on an H100 (FR3 cube, 32,768 episodes, batches fed from 4,096 up to 8,192 worlds,
# 2026-11-26, docs/engines.md "Retiring finished worlds"): 0.25 cut the motion's world-steps
# from 208 M to 130 M (padding 44% -> 10%) but not the device time (134 s against 129 s on
# another box in lockstep): the smaller segments stepped 1.54 M world-steps/s against 1.88 M,
# and each retirement makes a new data and captures a new graph while its batch holds the
# device's lock. So the engine keeps lockstep until a retirement that reuses its data pays.
RETIRE = 0.0
# No retirement below this many stepping worlds: a step of up to ~1,000 worlds is bound by
# latency on an H100 (1.56 M world-steps/s at 1,024 worlds, ~0.66 ms a step, against ~2.6 ms
# at 16,384; docs/engines.md), so fewer worlds would not step faster. Chosen, from that
# measurement.
MIN_WORLDS = 1024


@dataclass(frozen=True)
class Segment:
    """Control steps up to ``end`` (exclusive) of the batch worlds ``worlds`` (by span)."""

    end: int
    worlds: np.ndarray


def segments(
    spans: np.ndarray, retire: float = RETIRE, min_worlds: int = MIN_WORLDS
) -> list[Segment]:
    """Split the motion so that worlds leave when ``retire`` of the stepping ones have ended
    their spans; every world steps at least its span; ``retire`` 0: one lockstep segment."""
    rows = int(spans.max())
    alive = np.argsort(spans, kind="stable").astype(np.int32)
    out: list[Segment] = []
    while True:
        k = max(1, math.ceil(retire * len(alive)))
        end = int(spans[alive[k - 1]])
        if retire <= 0 or len(alive) <= min_worlds or end >= rows:
            out.append(Segment(rows, alive))
            return out
        out.append(Segment(end, alive))
        alive = alive[spans[alive] > end]
