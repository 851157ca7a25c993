"""Tug ladders with their rungs in a stream's lanes (harness.engines.mjwarp.lane_tug), on fake
rung outcomes: whatever order and batch sizes the lanes serve the rungs in, each ladder runs
the rungs the batch rounds run and ends with the same known rungs, so its result is the CPU
ladder's; an overflowed rung drops its ladder once and its queued rungs are never loaded."""

from __future__ import annotations

import random
from unittest import mock

import numpy as np
import pytest
from helpers import rung_outcomes
from hypothesis import given, settings
from hypothesis import strategies as st

from harness.engines.mjwarp import lane_tug
from harness.engines.mjwarp.lane_tug import LaneLadders, RungRequest, tug_in_lanes
from harness.engines.mjwarp.signals import HoldWindow
from harness.engines.mjwarp.tug import RUNGS, RoundPolicy, Rung, run_rounds
from harness.pick.validity import TUG_DIRECTIONS, RungOutcome

patterns = st.lists(
    st.fixed_dictionaries({r: rung_outcomes for r in RUNGS}), min_size=1, max_size=5
)
WEIGHT = 2.0  # N


def _window(hold_end: int) -> HoldWindow:
    return HoldWindow(rest_end=hold_end - 10, hold_end=hold_end)


def _serve(
    ladders: LaneLadders,
    worlds: list[dict[Rung, RungOutcome]],
    lanes: int,
    rng: random.Random,
    over: set[tuple[int, Rung]] = frozenset(),  # type: ignore[assignment]
) -> tuple[dict[int, dict[Rung, RungOutcome]], list[int], list[RungRequest]]:
    """Run the queue through ``lanes`` lanes, rungs ending in a random order: the complete
    ladders' known rungs by world, the dropped worlds, every request loaded."""
    running: list[RungRequest] = []
    loaded: list[RungRequest] = []
    known: dict[int, dict[Rung, RungOutcome]] = {}
    dropped: list[int] = []
    while ladders.queue or running:
        new = ladders.take(lanes - len(running))
        running += new
        loaded += new
        rng.shuffle(running)
        cut = rng.randint(1, len(running))
        ended, running = running[:cut], running[cut:]
        rows = [np.array([r.slot, RUNGS.index(r.rung)]) for r in ended]
        flags = [(r.slot, r.rung) in over for r in ended]
        complete, gone = ladders.ended([r.tag for r in ended], rows, flags)
        known.update({ladder.slot: dict(ladder.known) for ladder in complete})
        dropped += [ladder.slot for ladder in gone]
    return known, dropped, loaded


def _patched(worlds: list[dict[Rung, RungOutcome]]):  # type: ignore[no-untyped-def]
    def outcome(row: np.ndarray, held: np.ndarray) -> RungOutcome:
        return worlds[int(row[0])][RUNGS[int(row[1])]]

    return (
        mock.patch.object(lane_tug, "rung_outcome", outcome),
        mock.patch.object(lane_tug, "held_in_tcp", lambda rows, window: np.zeros(3)),
    )


@settings(max_examples=200, deadline=None)
@given(
    patterns,
    st.sampled_from([RoundPolicy.PATH_LOWER_ALL, RoundPolicy.PATH, RoundPolicy.ALL]),
    st.integers(1, 40),
    st.integers(0, 10_000),
)
def test_ladders_in_lanes_know_what_the_rounds_know(
    worlds: list[dict[Rung, RungOutcome]], policy: RoundPolicy, lanes: int, seed: int
) -> None:
    """Each ladder ends knowing exactly the rungs the batch rounds ran for its world (so its
    result is the CPU ladder's, ``test_tug_rounds``), every rung loaded once, from the end of
    the hold, with its pull; the rounds asked for add up over the ladders."""
    ladders = LaneLadders(WEIGHT, policy)
    first, second = _patched(worlds)
    with first, second:
        for w in range(len(worlds)):
            ladders.start(object(), w, _window(100 + w), np.zeros((1, 1)), motion=90)
        known, dropped, loaded = _serve(ladders, worlds, lanes, random.Random(seed))
    log: list[list[tuple[int, Rung]]] = []

    def run(batch: list[tuple[int, Rung]]) -> list[RungOutcome]:
        log.append(batch)
        return [worlds[w][r] for w, r in batch]

    expected, stats = run_rounds(list(range(len(worlds))), run, policy)
    assert known == expected and not dropped and ladders.open == 0
    assert len(loaded) == stats.rungs == len({(r.slot, r.rung) for r in loaded})
    rounds_of = [sum(any(v == w for v, _ in batch) for batch in log) for w in range(len(worlds))]
    assert ladders.rounds == sum(rounds_of)
    directions = dict(TUG_DIRECTIONS)
    for request in loaded:
        # the hold's end (100 + slot), counted from the motion's last row (89)
        assert request.saved == 100 + request.slot - 89
        name, k = request.rung
        assert np.allclose(request.force, np.asarray(directions[name]) * k * WEIGHT)


def test_an_overflowed_rung_drops_its_ladder_once_and_its_queued_rungs() -> None:
    """World 0's first top-level rung does not fit: its ladder is dropped once (its job reruns
    whole), the rest of its rungs are never loaded once dropped, and world 1's ladder ends."""
    held_all: dict[Rung, RungOutcome] = {r: (True, 0.0, True) for r in RUNGS}
    worlds = [held_all, held_all]
    ladders = LaneLadders(WEIGHT)
    first, second = _patched(worlds)
    with first, second:
        ladders.start(object(), 0, _window(100), np.zeros((1, 1)), motion=90)
        ladders.start(object(), 1, _window(100), np.zeros((1, 1)), motion=90)
        top = ladders.queue[0].rung
        # one lane: rungs end one at a time, so world 0's other rungs are still queued
        known, dropped, loaded = _serve(ladders, worlds, 1, random.Random(0), {(0, top)})
    assert dropped == [0] and list(known) == [1] and ladders.open == 0
    assert [r.slot for r in loaded].count(0) == 1  # only the overflowed one ran
    assert len(known[1]) == len(TUG_DIRECTIONS)  # held the top level in every direction


def test_rungs_run_in_the_lanes_only_when_asked(monkeypatch: pytest.MonkeyPatch) -> None:
    """Off by default (measured no faster); ``HARNESS_TUG_LANES=1`` turns it on, except for a
    stream whose replays are queued ahead."""
    monkeypatch.delenv("HARNESS_TUG_LANES", raising=False)
    assert not tug_in_lanes()
    monkeypatch.setenv("HARNESS_TUG_LANES", "1")
    assert tug_in_lanes() and not tug_in_lanes(ahead=True)
    monkeypatch.setenv("HARNESS_TUG_LANES", "0")
    assert not tug_in_lanes()
