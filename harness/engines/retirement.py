"""When worlds leave a batch's lockstep motion: its segments (``mjwarp_motion`` steps them).

Pure arithmetic on the worlds' spans (control steps each must be stepped: its schedule, then
its validity window), so that the plan is tested without a device.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# A segment ends when this share of its worlds has reached the end of its span. Chosen, no
# public source: each retirement costs a new data and a new CUDA graph (host time while the
# device waits for this batch), so a batch of 8,192 retires in ~8 steps rather than at every
# world's end.
RETIRE = 0.25
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
