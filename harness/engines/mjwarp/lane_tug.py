"""Tug ladders whose rungs run in a stream's own lanes, one ladder per job, each at its pace.

A lockstep batch tugs in rounds (``tug.run_rounds``): every tugged world's next rungs wait for
the whole round before. In a lane stream each finished job's ladder asks for its next rungs as
soon as its last ones ended, by the same policy (``tug.round_rungs``), and a rung's outcome is
read from its end row by the same rule (``judge.rung_outcome``). A rung's result does not depend
on when or beside what it runs, so each ladder's rungs and result are those of the rounds.

The rungs wait in ``queue`` until the stream loads them into free lanes
(``LaneRun.load_rungs``), before new jobs: a rung frees its job's slot sooner, and its steps
would otherwise be a batch of their own beside the lanes (on two H100s, 2026-11-28 morning, tug
rounds took 81-98 s of each stream's ~200 s while 63% of the lane-steps idled). Measured since:
no faster where planning feeds the lanes, slower for streams of a few jobs; so it is off by
default (``tug_in_lanes``).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from harness.engines.mjwarp.judge import held_in_tcp, rung_outcome
from harness.engines.mjwarp.lane_sizes import env_flag
from harness.engines.mjwarp.signals import HoldWindow
from harness.engines.mjwarp.tug import (
    DEFAULT_POLICY,
    RoundPolicy,
    Rung,
    round_rungs,
    rung_pull,
    rung_start_slot,
)
from harness.pick.validity import RungOutcome

# Where the tug's rungs run: with ``HARNESS_TUG_LANES=1``, in the stream's own free lanes;
# by default (and always with ``HARNESS_LANE_AHEAD=1``) in rounds of a batch of their own on a
# CUDA stream beside the lanes (``stream.LaneStream._tug``). Measured on one H100 (16 cores,
# 2026-11-28, docs/engines.md "The sittings of 2026-11-28, noon"), beside against in the lanes:
# the demo 94.1 s against 121.0 s (its streams of 128 lanes hold a few jobs each, so a ladder's
# rounds in line lengthen them), issue 34's FR3 sweep 53.9 s against 56.5 s (1,024 lanes), its
# 45,000-row version 297.8 s against 296.5 s (8,192 lanes, planning the bound). No win: off.
TUG_LANES_ENV = "HARNESS_TUG_LANES"


def tug_in_lanes(ahead: bool = False) -> bool:
    """Whether a stream runs its tug rungs in its lanes: as ``HARNESS_TUG_LANES`` says (1 or
    0; default 0), never when its replays are queued ahead (a lane's rung row would be read
    one visit late)."""
    return not ahead and env_flag(TUG_LANES_ENV)


@dataclass
class Ladder:
    """One job's tug ladder: the job (the stream's item), its job slot and hold window, the
    saved state its rungs start from (the end of the hold), the object's place in the TCP frame
    there, the rungs known so far and those asked for."""

    item: Any
    slot: int
    window: HoldWindow
    saved: int
    held: np.ndarray
    known: dict[Rung, RungOutcome] = field(default_factory=dict)
    waiting: set[Rung] = field(default_factory=set)
    dropped: bool = False  # a rung did not fit the buffers: the job runs again whole


@dataclass(frozen=True)
class RungRequest:
    """A rung to load into a lane: its tag, its job slot, the saved state it starts from (the
    end of the hold), which rung it is and its pull on the object (N, world frame)."""

    tag: int
    slot: int
    saved: int
    rung: Rung
    force: np.ndarray


class LaneLadders:
    """The open ladders of one stream and the rungs they wait for."""

    def __init__(self, weight: float, policy: RoundPolicy = DEFAULT_POLICY) -> None:
        """``weight``: the target object's weight (N); a rung of ``k`` g pulls ``k`` times it."""
        self.weight, self.policy = weight, policy
        self.queue: deque[RungRequest] = deque()
        self._tags: dict[int, tuple[Ladder, Rung]] = {}
        self._next_tag = 0
        self.rounds = 0  # rounds asked for, summed over the ladders
        self.open = 0  # ladders not yet complete

    def start(
        self, item: Any, slot: int, window: HoldWindow, rows: np.ndarray, motion: int
    ) -> None:
        """Open ``item``'s ladder (its job in ``slot``, signal ``rows``, ``motion`` control
        steps) and queue its first rungs (every policy asks for some at first)."""
        saved = rung_start_slot(window.hold_end, motion)
        ladder = Ladder(item, slot, window, saved, held_in_tcp(rows, window))
        self.open += 1
        self._ask(ladder)

    def _ask(self, ladder: Ladder) -> bool:
        """Queue the ladder's next rungs; False when it asks for none (it is complete)."""
        rungs = round_rungs(ladder.known, self.policy)
        if not rungs:
            return False
        self.rounds += 1
        for rung in rungs:
            tag = self._next_tag
            self._next_tag += 1
            self._tags[tag] = (ladder, rung)
            ladder.waiting.add(rung)
            force = rung_pull(rung, self.weight)
            self.queue.append(RungRequest(tag, ladder.slot, ladder.saved, rung, force))
        return True

    def take(self, count: int) -> list[RungRequest]:
        """Up to ``count`` queued rungs, skipping those of dropped ladders."""
        out: list[RungRequest] = []
        while self.queue and len(out) < count:
            request = self.queue.popleft()
            ladder, _ = self._tags[request.tag]
            if ladder.dropped:
                del self._tags[request.tag]
            else:
                out.append(request)
        return out

    def ended(
        self, tags: list[int], rows: list[np.ndarray], overflowed: list[bool]
    ) -> tuple[list[Ladder], list[Ladder]]:
        """Rungs that ended in the lanes: the ladders completed by them, and those dropped (a
        rung did not fit the buffers; each is dropped once)."""
        complete, dropped = [], []
        for tag, row, over in zip(tags, rows, overflowed, strict=True):
            ladder, rung = self._tags.pop(tag)
            if ladder.dropped:
                continue
            if over:
                ladder.dropped = True
                self.open -= 1
                dropped.append(ladder)
                continue
            ladder.known[rung] = rung_outcome(row, ladder.held)
            ladder.waiting.discard(rung)
            if not ladder.waiting and not self._ask(ladder):
                self.open -= 1
                complete.append(ladder)
        return complete, dropped
