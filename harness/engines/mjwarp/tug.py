"""The tug ladder of a batched engine, run in rounds of rungs (pure CPU: no device here).

The CPU executor runs ``harness.pick.validity.tug_ladder`` one rung at a time: each direction
tries the levels from the best one every earlier direction survived downwards. A batch cannot
ask the device one rung at a time per world, but a rung starts from the held state, so its
result does not depend on when it is run: the batch runs *rounds* of rungs and evaluates the
same ``tug_ladder`` with an oracle that answers from the rungs computed so far.

A round asks, per world, for the rungs on the ladder's *optimistic path*: the ladder walked with
every rung not yet computed assumed survived (round 1: every direction at the top level, six
rungs). The first of them is certainly needed (the walk agrees with the real ladder up to it);
the others are needed when it survives. ``PATH_LOWER`` also asks, from round 2 on, for the
levels below the first missing rung in its direction, which that direction tries next when the
rung fails; ``PATH_LOWER_ALL`` for the levels below every missing rung of the path, which
completes every ladder in at most two rounds (round 2 then holds every level a direction can
still be asked for).
A world is done when its walk meets no missing rung: that walk *is* the real ladder, so its
result is the one the CPU's ladder would give on the same rung outcomes. ``ALL`` (every rung in
the first round) is the unadaptive reference the rounds are tested against.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from enum import Enum

import numpy as np

from harness.engines.mjwarp.lane_sizes import env_int
from harness.pick.validity import TUG_DIRECTIONS, TUG_LEVELS_G, RungOutcome, tug_ladder

# A tug rung: (direction name, level in g).
Rung = tuple[str, float]
# Every rung, direction-major, levels ascending.
RUNGS: tuple[Rung, ...] = tuple((name, k) for name, _ in TUG_DIRECTIONS for k in TUG_LEVELS_G)
_DIRECTIONS = dict(TUG_DIRECTIONS)


def rung_pull(rung: Rung, weight: float) -> np.ndarray:
    """A rung's pull on the object (N, world frame): its direction times its level (g) times
    the object's ``weight`` (N)."""
    name, k = rung
    return np.asarray(_DIRECTIONS[name], dtype=float) * k * weight


def rung_start_slot(hold_end: int, motion: int) -> int:
    """The saved state a rung starts from, the end of the hold (signal row ``hold_end``), as an
    index of a world's saved states, which start at its motion's last row
    (``kernels.save_state``; ``motion`` control steps)."""
    return hold_end - (motion - 1)


# Runs one round's (world, rung) pairs on the engine; their outcomes in the same order.
RoundRunner = Callable[[list[tuple[int, Rung]]], list[RungOutcome]]
# What a round assumes of a rung not yet computed: survived (the optimistic path).
_ASSUMED: RungOutcome = (True, 0.0, True)


class RoundPolicy(Enum):
    """Which rungs a round asks for; see the module doc."""

    ALL = "all"  # every rung in round 1 (the 24-rung reference)
    PATH = "path"  # the optimistic path's missing rungs
    PATH_LOWER = "path+lower"  # those, and the levels below the first in its direction
    PATH_LOWER_ALL = "path+lower-all"  # those, and the levels below each in its direction


# The batched engine's policy: at most two rounds, for a few more rung-worlds than PATH
# (docs/engines.md: on a device a round of a few worlds costs about what one of a thousand
# does, so rounds cost more than the rungs they save).
DEFAULT_POLICY = RoundPolicy.PATH_LOWER_ALL


def steps_per_graph() -> int:
    """Physics steps a tug round captures in one CUDA graph (``HARNESS_TUG_STEPS_PER_GRAPH``;
    default 1, a graph launch per physics step, as measured so far). A round issues its 0.5 s of
    steps one launch at a time: on two H200s the tug took 51-55 s of each stream's ~150 s, all
    of it issuing (docs/engines.md, "The sittings of 2026-11-28"); more steps a graph issue fewer
    launches for the same kernels. Not yet measured on a GPU, so off."""
    return env_int("HARNESS_TUG_STEPS_PER_GRAPH") or 1


@dataclass(frozen=True)
class LadderWalk:
    """The ladder evaluated on the known rungs: the missing rungs of its optimistic path, in the
    order it asks for them, and its result (final only when ``missing`` is empty)."""

    missing: tuple[Rung, ...]
    result: tuple[float, str]

    @property
    def done(self) -> bool:
        return not self.missing


def walk(known: Mapping[Rung, RungOutcome]) -> LadderWalk:
    """``tug_ladder`` answered from ``known``, a rung not in it assumed survived."""
    missing: list[Rung] = []

    def rung(name: str, direction: tuple[float, float, float], k: float) -> RungOutcome:
        outcome = known.get((name, k))
        if outcome is None:
            missing.append((name, k))
            return _ASSUMED
        return outcome

    result = tug_ladder(rung)
    return LadderWalk(tuple(missing), result)


def round_rungs(known: Mapping[Rung, RungOutcome], policy: RoundPolicy) -> list[Rung]:
    """The rungs one world runs in its next round (empty: its ladder is complete)."""
    if policy is RoundPolicy.ALL:
        return [r for r in RUNGS if r not in known]
    missing = list(walk(known).missing)
    if not known or policy is RoundPolicy.PATH:
        return missing
    extend = missing[:1] if policy is RoundPolicy.PATH_LOWER else list(missing)
    for name, k in extend:
        below = [(name, level) for level in reversed(TUG_LEVELS_G) if level < k]
        missing += [r for r in below if r not in known and r not in missing]
    return missing


@dataclass
class RoundStats:
    """How many rounds the ladders took and how many rungs (worlds) they ran in all."""

    rounds: int = 0
    rungs: int = 0


def run_rounds(
    worlds: list[int],
    run: RoundRunner,
    policy: RoundPolicy = DEFAULT_POLICY,
) -> tuple[dict[int, dict[Rung, RungOutcome]], RoundStats]:
    """Rounds until every world's ladder is complete: ``run`` gets one round's (world, rung)
    pairs and returns their outcomes in the same order. The known rungs of each world, and the
    count of rounds and rung-worlds."""
    known: dict[int, dict[Rung, RungOutcome]] = {w: {} for w in worlds}
    stats = RoundStats()
    while True:
        batch = [(w, r) for w in worlds for r in round_rungs(known[w], policy)]
        if not batch:
            return known, stats
        stats.rounds += 1
        stats.rungs += len(batch)
        for (w, r), outcome in zip(batch, run(batch), strict=True):
            known[w][r] = outcome
