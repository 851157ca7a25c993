"""The batched engine's tug rounds (harness.engines.mjwarp.tug), on fake rung outcomes: the
ladder's result is the one tug_ladder gives when every rung is known, whatever the pattern of
survived rungs, for every round policy."""

from __future__ import annotations

from helpers import rung_outcomes
from hypothesis import given, settings
from hypothesis import strategies as st

from harness.engines.mjwarp.tug import RUNGS, RoundPolicy, Rung, run_rounds, walk
from harness.pick.validity import TUG_DIRECTIONS, TUG_LEVELS_G, RungOutcome, tug_ladder

TOP = TUG_LEVELS_G[-1]

patterns = st.lists(
    st.fixed_dictionaries({r: rung_outcomes for r in RUNGS}), min_size=1, max_size=6
)


def _full(pattern: dict[Rung, RungOutcome]) -> tuple[float, str]:
    """The CPU's ladder, asking the pattern rung by rung."""
    return tug_ladder(lambda name, direction, k: pattern[(name, k)])


def _asked(pattern: dict[Rung, RungOutcome]) -> list[Rung]:
    """The rungs the CPU's ladder asks for, in order."""
    asked: list[Rung] = []

    def rung(name: str, direction: tuple[float, float, float], k: float) -> RungOutcome:
        asked.append((name, k))
        return pattern[(name, k)]

    tug_ladder(rung)
    return asked


def _runner(worlds: list[dict[Rung, RungOutcome]], log: list[list[tuple[int, Rung]]]):
    def run(batch: list[tuple[int, Rung]]) -> list[RungOutcome]:
        log.append(batch)
        return [worlds[w][r] for w, r in batch]

    return run


@settings(max_examples=300, deadline=None)
@given(patterns, st.sampled_from(list(RoundPolicy)))
def test_rounds_give_the_full_ladders_result(
    worlds: list[dict[Rung, RungOutcome]], policy: RoundPolicy
) -> None:
    """Each world's ladder, answered from the rungs its rounds ran, gives tug_ladder's
    (robustness_g, message) on all 24; no rung runs twice; round 1 runs every direction at the
    top level (all 24 under ALL); a world takes at most as many rounds as the CPU ladder asks
    rungs."""
    log: list[list[tuple[int, Rung]]] = []
    known, stats = run_rounds(list(range(len(worlds))), _runner(worlds, log), policy)
    assert stats.rounds == len(log) and stats.rungs == sum(len(b) for b in log)
    rounds_of = [sum(any(v == w for v, _ in batch) for batch in log) for w in range(len(worlds))]
    assert stats.rounds == max(rounds_of)
    if policy is RoundPolicy.PATH_LOWER_ALL:
        assert stats.rounds <= 2  # round 2 holds every level a direction can still be asked
    for w, pattern in enumerate(worlds):
        ladder = walk(known[w])
        assert ladder.done
        assert ladder.result == _full(pattern)
        ran = [r for batch in log for v, r in batch if v == w]
        assert len(ran) == len(set(ran)) == len(known[w])
        first = [r for v, r in log[0] if v == w]
        if policy is RoundPolicy.ALL:
            assert sorted(first) == sorted(RUNGS) and stats.rounds == 1
        else:
            assert first == [(name, TOP) for name, _ in TUG_DIRECTIONS]
            asked = _asked(pattern)
            assert set(asked) <= set(known[w])
            assert rounds_of[w] <= len(asked)  # each round runs a rung the ladder asks for


def test_a_grasp_that_holds_the_top_level_takes_one_round_of_six() -> None:
    """Survives every pull: six rungs in one round, robustness the top level, no message."""
    held = {r: (True, 0.001, True) for r in RUNGS}
    for policy in (RoundPolicy.PATH, RoundPolicy.PATH_LOWER):
        known, stats = run_rounds([0], _runner([held], []), policy)
        assert (stats.rounds, stats.rungs) == (1, 6)
        assert walk(known[0]).result == (TOP, "")


def test_a_failed_top_rung_asks_the_next_level_and_the_others_at_it() -> None:
    """+x fails at 4 g and holds 2 g, every other direction holds 2 g but not 4 g: round 2
    (PATH) asks +x at 2 g and, optimistically, the five others at 2 g; PATH_LOWER adds +x at
    1 and 0.5 g. Both end in two rounds at 2 g with the first failure's message."""
    pattern = {(name, k): (k <= 2.0, 0.02 if k > 2.0 else 0.001, True) for name, k in RUNGS}
    log: list[list[tuple[int, Rung]]] = []
    known, stats = run_rounds([0], _runner([pattern], log), RoundPolicy.PATH)
    assert log[1] == [(0, (name, 2.0)) for name, _ in TUG_DIRECTIONS]
    assert (stats.rounds, stats.rungs) == (2, 12)
    assert walk(known[0]).result == (2.0, "+x at 4 g: slip 20.0 mm, between the fingers")
    log.clear()
    known, stats = run_rounds([0], _runner([pattern], log), RoundPolicy.PATH_LOWER)
    assert log[1][:2] == [(0, ("+x", 2.0)), (0, ("-x", 2.0))]
    assert (0, ("+x", 1.0)) in log[1] and (0, ("+x", 0.5)) in log[1]
    assert (stats.rounds, stats.rungs) == (2, 14)
    assert walk(known[0]).result == _full(pattern)


def test_a_tug_rounds_graphs_cover_its_steps() -> None:
    """``graph_plan`` (how ``steps.replay`` cuts a run of steps): after the first (eager)
    step, graphs of ``per_graph`` steps and one for the rest replay every step once (a tug round
    of 250 steps at 8 a graph: 31 replays of 8 and one of 1)."""
    from harness.engines.mjwarp.graph_plan import graph_plan

    assert graph_plan(250, 1) == [(1, 249)]  # the default: a launch per physics step
    assert graph_plan(250, 8) == [(8, 31), (1, 1)]
    assert graph_plan(9, 8) == [(8, 1)]
    assert graph_plan(3, 8) == [(2, 1)]
    assert graph_plan(1, 8) == []
    for times in range(1, 60):
        for per_graph in (1, 3, 8, 64):
            plan = graph_plan(times, per_graph)
            assert 1 + sum(calls * launches for calls, launches in plan) == times
            assert len(plan) <= 2
