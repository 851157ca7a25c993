"""The tune's decision logic on constructed paired outcomes (no episodes): ties keep the
current setting, a clear gain switches, Holm corrects for the racers, a fallback setting is
never recommended, a close race is undecided with the seeds that would settle it; and the grid
is deduplicated by what each filter keeps."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import binomtest

from harness.tuning.decide import (
    KEEP,
    STOP_PLAN,
    SWITCH,
    UNDECIDED,
    Racer,
    UnitRace,
    advance,
    holm,
    one_sided_mcnemar,
    verdict,
)
from harness.tuning.grid import approach_values, axis_values, facing_values, filter_key
from harness.tuning.sequential import Plan

BLOCK = 10


def race_on(outcomes: list[list[bool]], looks: int, fallback: int | None = None) -> UnitRace:
    """Race settings whose outcomes per seed are given (row 0: the current setting)."""
    racers = [Racer(("a", str(k)), k, fallback=k == fallback) for k in range(len(outcomes))]
    race = UnitRace(racers, Plan(looks * BLOCK, BLOCK, challengers=len(outcomes) - 1))
    while not race.stopped:
        start = race.look * BLOCK
        advance(race, {k: row[start : start + BLOCK] for k, row in enumerate(outcomes)})
    return race


def test_ties_keep_the_current_setting() -> None:
    rng = np.random.default_rng(0)
    same = list(rng.random(40) < 0.7)
    race = race_on([same, same, same, same], looks=4)
    decided = verdict(race)
    assert decided.verdict == KEEP and decided.chosen is None
    # Identical outcomes: no discordant seed, so no gain is seen and none is rejected (too few
    # discordant seeds for Newcombe's bound): the race runs its plan, and the tie keeps.
    assert race.stopped == STOP_PLAN and race.look == 4
    assert decided.seeds == race.look * BLOCK


def test_a_clear_gain_switches_with_its_confirming_look() -> None:
    current = [i % 2 == 0 for i in range(40)]  # 50%
    better = [True] * 40  # wins every seed the current loses: 20 discordant, all one way
    race = race_on([current, current, better], looks=4)
    decided = verdict(race)
    assert decided.verdict == SWITCH and decided.chosen is not None
    assert decided.chosen.rank == 2
    # Look 1 (10 seeds, 5 discordant all one way): p = 1/32, not below 0.05 / 4 / 2 (Holm
    # over the 2 challengers); look 2 (10 discordant): p = 2^-10 confirms it.
    first = decided.chosen.confirmed_at
    assert first == 2
    assert decided.chosen.p_value <= 0.05 / 4


def test_holm_corrects_for_the_number_of_racers() -> None:
    # Three claims at p = 0.01, 0.02, 0.04 at level 0.05: unadjusted all reject; Holm rejects
    # the first (0.01 <= 0.05/3), then 0.02 <= 0.05/2, then 0.04 <= 0.05.
    reject, adjusted = holm([0.01, 0.02, 0.04], 0.05)
    assert reject == [True, True, True]
    assert adjusted == pytest.approx([0.03, 0.04, 0.04])
    reject, adjusted = holm([0.02, 0.03, 0.04], 0.05)
    assert reject == [False, False, False]  # 0.02 > 0.05 / 3
    assert adjusted[0] == pytest.approx(0.06)


def test_holm_agrees_with_statsmodels(monkeypatch: pytest.MonkeyPatch) -> None:
    import gc

    from statsmodels.stats.multitest import multipletests

    # multipletests(method="holm") ends with gc.collect() (memory only: its results do not
    # depend on it); late in the whole suite's process the 80 full collections took 65 s.
    monkeypatch.setattr(gc, "collect", lambda generation=2: 0)
    rng = np.random.default_rng(3)
    for size in (1, 2, 3, 5):
        for _ in range(20):
            p_values = list(rng.random(size) ** 3)
            reject, adjusted, _, _ = multipletests(p_values, alpha=0.0125, method="holm")
            ours = holm(p_values, 0.0125)
            assert ours[0] == list(reject)
            assert ours[1] == pytest.approx(list(adjusted))


def test_holm_turns_an_uncorrected_win_into_undecided() -> None:
    """One look, three challengers: 5 discordant seeds all one way is p = 1/32 = 0.031 <
    0.05 alone, but not under Holm over three racers (0.031 > 0.05 / 3)."""
    current = [True] * 5 + [False] * 5
    lucky = [True] * 10
    assert one_sided_mcnemar(5, 0) == pytest.approx(1 / 32)
    assert one_sided_mcnemar(5, 0) == pytest.approx(binomtest(5, 5, 0.5, "greater").pvalue)
    single = race_on([current, lucky], looks=1)
    assert verdict(single).verdict == SWITCH
    crowded = race_on([current, lucky, current, current], looks=1)
    decided = verdict(crowded)
    assert decided.verdict == UNDECIDED
    assert [r.rank for r in decided.contenders] == [1]
    assert decided.seeds_needed > 10


def test_a_fallback_setting_is_never_recommended() -> None:
    current = [i % 2 == 0 for i in range(40)]
    race = race_on([current, [True] * 40, current], looks=4, fallback=1)
    decided = verdict(race)
    assert decided.verdict == KEEP
    assert race.racers[1].dropped_at == 1 and not race.racers[1].alive


def test_the_leader_drops_a_setting_shown_worse() -> None:
    good = [True] * 40
    bad = [i % 4 == 0 for i in range(40)]  # loses 30 of 40 seeds the others win
    race = race_on([good, good, bad], looks=4)
    assert race.racers[2].dropped_at is not None and race.racers[0].alive
    assert verdict(race).verdict == KEEP


def test_grid_deduplicates_filters_that_keep_the_same_axes() -> None:
    assert filter_key(["downward", 90.0]) == filter_key(["downward", 90.0, 180.0])
    assert filter_key(["forward", 180.0]) is None and filter_key(["forward", 180.0, 0.0]) is None
    assert filter_key(["downward", 135.0]) != filter_key(["downward", 140.0])
    approach = axis_values(approach_values(15, 1), [["downward", 140.0]])
    facing = axis_values(facing_values(15, 1), [["forward", 90.0]])
    assert len(approach_values(15, 1)) + 1 == 8 and len(facing_values(15, 1)) == 7
    assert (len(approach), len(facing)) == (7, 6)  # 56 points -> 42 distinct settings
    assert ["downward", 140.0] in approach and ["downward", 90.0, 180.0] not in approach
    # A current setting given as the band keeps its own spelling; the equal single angle goes.
    banded = axis_values(approach_values(15, 1), [["downward", 90.0, 180.0]])
    assert ["downward", 90.0, 180.0] in banded and ["downward", 90.0] not in banded


def test_objects_pool_into_one_file_decision_only_when_they_agree() -> None:
    import pandas as pd

    from harness.tuning.decisions import file_decision

    def rows(*verdicts: tuple[str, str]) -> pd.DataFrame:
        return pd.DataFrame(
            [
                {"verdict": v, "approach": a, "facing": "f", "current_approach": "now",
                 "current_facing": "f"}
                for v, a in verdicts
            ]
        )  # fmt: skip

    same = file_decision(rows((SWITCH, "x"), (SWITCH, "x")))
    assert same == {"verdict": SWITCH, "setting": ("x", "f"), "agree": True}
    split = file_decision(rows((SWITCH, "x"), (KEEP, "now")))
    assert split == {"verdict": KEEP, "setting": ("now", "f"), "agree": False}
    apart = file_decision(rows((SWITCH, "x"), (SWITCH, "y")))
    assert apart["agree"] is False and apart["setting"] == ("now", "f")


def test_budget_in_episodes_or_seconds() -> None:
    from harness.tuning.race import Budget

    assert Budget.parse(None) == Budget() and not Budget().spent(10**6, 1e9)
    assert Budget.parse("400") == Budget(episodes=400)
    assert Budget.parse("400").spent(400, 0.0) and not Budget.parse("400").spent(399, 1e9)
    assert Budget.parse("300s") == Budget(seconds=300.0)
    assert Budget.parse("300s").spent(0, 300.0) and not Budget.parse("300s").spent(10**6, 299.0)


def test_the_coarse_pass_spans_every_pick_direction_on_both_axes() -> None:
    """Forward, backward, upward and downward (Pick's four names; left/right are Place's) at a
    quadrant and a hemisphere, on the approach and the facing axis; every band of every
    direction follows the reference's order rule (a non-empty range of cosines)."""
    from harness.config import load_task
    from harness.tuning.grid import (
        APPROACH_KEY,
        DIRECTIONS,
        FACING_KEY,
        coarse_values,
        direction_of,
        tune_sweep,
    )

    task = load_task(Path(__file__).resolve().parents[1] / "tasks" / "pick" / "fr3.yaml")
    sweep = tune_sweep([task], {}, step=15, bands=2, episodes=1, seed=0, coarse=True)
    for key in (APPROACH_KEY, FACING_KEY):
        names = {direction_of(json.dumps(v)) for v in sweep.axes[key]}
        assert names >= set(DIRECTIONS)
    assert ["backward", 135.0] in coarse_values() and ["upward", 45.0] in coarse_values()
    for direction in DIRECTIONS:
        for value in [*approach_values(15, 2, direction), *facing_values(15, 2, direction)]:
            key = filter_key(value)
            assert value[0] == direction and (key is None or key[1] < key[2]), value
    # The refine pass about backward facing holds issue 35's [backward, 40] at step 10 (140).
    assert ["backward", 40.0] in facing_values(10, 0, "backward")


def test_a_second_pass_never_counts_a_seed_twice() -> None:
    import pandas as pd

    from harness.tuning.analysis import merge_passes

    def frame(settings: list[tuple[str, str]], first_id: int) -> pd.DataFrame:
        rows = [
            {"task": "t", "context": "{}", "approach": a, "facing": f, "point_id": first_id + i,
             "ok": True}
            for i, (a, f) in enumerate(settings)
        ]  # fmt: skip
        return pd.DataFrame(rows)

    first = frame([('["downward", 90.0]', '["forward", 90.0]')], 0)
    later = frame(
        [('["downward", 90.0, 180.0]', '["forward", 90.0]'), ('["downward", 120.0]', "null")], 0
    )
    merged = merge_passes(first, later)
    assert len(merged) == 2  # the band keeps what downward 90 keeps: already screened
    assert list(merged["point_id"]) == [0, 2]
