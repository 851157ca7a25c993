"""The race's statistics by simulation (numpy, seeded): the group-sequential levels spend
alpha, the quoted intervals cover, a continued race is the same test, a cut-short race decides
nothing, ties among confirmed challengers follow the stated rule, "no setting helps" names its
cause, and a tune's options and budget refuse bad input with one line."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from race_simulation import draw, vector_races

from harness.errors import HarnessError
from harness.tuning.causes import cause_sentence
from harness.tuning.decide import (
    KEEP,
    NO_SETTING_HELPS,
    STOP_FLOOR,
    SWITCH,
    UNDECIDED,
    Racer,
    UnitRace,
    advance,
    verdict,
)
from harness.tuning.intervals import (
    exact_interval,
    paired_gain_bounds,
    paired_gain_interval,
)
from harness.tuning.race import Budget
from harness.tuning.sequential import (
    Plan,
    boundaries,
    look_times,
    nominal_levels,
    seeds_for_power,
)

RUNS = 3000


def test_levels_spend_alpha_over_the_looks() -> None:
    """Brownian paths (the McNemar z-statistic's limit) cross the plan's boundaries in 5% of
    paths under no gain; each look's nominal level is above the Bonferroni share."""
    for seeds, block in ((100, 20), (660, 20)):
        times = np.asarray(look_times(seeds, block))
        steps = np.diff(np.concatenate([[0.0], times]))
        rng = np.random.default_rng(7)
        paths = (rng.standard_normal((100_000, len(times))) * np.sqrt(steps)).cumsum(1)
        crossed = (paths >= np.asarray(boundaries(seeds, block, 0.05))).any(1).mean()
        assert crossed == pytest.approx(0.05, abs=0.003)
        assert min(nominal_levels(seeds, block, 0.05)) > 0.05 / len(times)


def _races(current: float, new: float, plan: Plan, seed: int):
    return vector_races(current, new, plan, RUNS, 0.7, np.random.default_rng(seed))


CASES = [  # (current, challenger, plan): issue 35's lopsided cases, balanced ones
    (0.08, 0.54, Plan(100, 20)),
    (0.55, 0.85, Plan(100, 20)),
    (0.80, 0.94, Plan(100, 20)),
    (0.50, 0.60, Plan(300, 20)),
    (0.50, 0.55, Plan(1240, 25)),
]


@pytest.mark.parametrize(("current", "new", "plan"), CASES)
def test_confirmed_gain_and_rate_intervals_cover(current: float, new: float, plan: Plan) -> None:
    """The confirmed gain's Newcombe interval covers the true gain in >= 93% of the switches
    (nominal 95%; the conditional-on-discordance interval covered 42-67%), and the exact rate
    intervals at the race's stopping look cover both rates."""
    races = _races(current, new, plan, 5)
    switched = races.verdict == SWITCH
    assert switched.mean() > 0.5
    a, b, c, d = races.table.T
    lo, hi = paired_gain_interval(a, b, c, d)
    truth = new - current
    assert ((lo <= truth) & (truth <= hi))[switched].mean() >= 0.93
    n = a + b + c + d
    new_lo, new_hi = exact_interval(a + b, n)
    now_lo, now_hi = exact_interval(a + c, n)
    assert ((new_lo <= new) & (new <= new_hi))[switched].mean() >= 0.93
    assert ((now_lo <= current) & (current <= now_hi)).mean() >= 0.93


def test_scalar_and_vector_intervals_agree() -> None:
    rng = np.random.default_rng(2)
    for _ in range(50):
        counts = [int(v) for v in rng.integers(0, 30, 4)]
        assert paired_gain_bounds(*counts) == pytest.approx(
            [float(v) for v in paired_gain_interval(*counts)]
        )
    assert paired_gain_bounds(12, 9, 2, 16)[0] < (9 - 2) / 39 < paired_gain_bounds(12, 9, 2, 16)[1]


def _scalar_race(outcomes: np.ndarray, plan: Plan) -> UnitRace:
    """The tune's own race (``harness.tuning.decide``) on (settings, seeds) outcomes."""
    race = UnitRace([Racer(("a", str(k)), k) for k in range(len(outcomes))], plan)
    while not race.stopped:
        start, stop = race.seeds_of(race.look), race.seeds_of(race.look + 1)
        advance(race, {k: list(outcomes[k, start:stop]) for k in range(len(outcomes))})
    return race


def test_vector_races_are_the_tunes_race() -> None:
    """The vectorized simulation decides as the tune's own race on the same outcomes."""
    plan = Plan(60, 10)
    rng = np.random.default_rng(11)
    for current, new in ((0.5, 0.75), (0.8, 0.8), (0.05, 0.05)):
        outcomes = np.stack([draw([current, new], plan.seeds, 0.7, rng) for _ in range(30)])
        vector = vector_races(current, new, plan, 30, 0.7, rng, outcomes)
        for i in range(30):
            race = _scalar_race(outcomes[i], plan)
            assert (verdict(race, evidence=False).verdict, race.look) == (
                vector.verdict[i],
                vector.look[i],
            )


def test_a_continued_race_is_the_same_test() -> None:
    """A race cut by its budget after one look and continued on the same --out (its rows
    replayed at the plan's levels, then the next looks) decides as the uninterrupted race on
    the same seeds, so re-running an undecided tune spends no new alpha; the race's
    false-switch rate with three equal challengers stays below alpha."""
    plan = Plan(60, 20, challengers=3)
    rng = np.random.default_rng(3)
    switches = 0
    for _ in range(100):
        outcomes = draw([0.6] * 4, plan.seeds, 0.7, rng)
        whole = _scalar_race(outcomes, plan)
        cut = UnitRace([Racer(("a", str(k)), k) for k in range(4)], plan)
        advance(cut, {k: list(outcomes[k, :20]) for k in range(4)})
        if not cut.stopped:
            assert verdict(cut, "budget 80 spent", False).verdict == UNDECIDED  # never keep
        again = _scalar_race(outcomes, plan)  # the rerun: stored looks replayed, then more
        decided = verdict(whole, evidence=False).verdict
        assert (verdict(again, evidence=False).verdict, again.look) == (decided, whole.look)
        switches += decided == SWITCH
    assert switches / 100 <= 0.05
    null = _races(0.6, 0.6, Plan(100, 20), 9)
    assert (null.verdict == SWITCH).mean() <= 0.05 + 2 * math.sqrt(0.05 * 0.95 / RUNS)


def test_a_race_cut_before_its_first_look_or_mid_race_is_undecided() -> None:
    plan = Plan(40, 10, challengers=1)
    race = UnitRace([Racer(("a", "0"), 0), Racer(("a", "1"), 1)], plan)
    assert verdict(race).verdict == UNDECIDED
    assert "first look" in verdict(race).reason
    same = [True, False] * 5
    advance(race, {0: same, 1: same})
    assert not race.stopped  # one look of four: a live race goes on
    decided = verdict(race, "race rows not stored (--analyse runs nothing)")
    assert decided.verdict == UNDECIDED and decided.chosen is None
    assert decided.reason.startswith("race rows not stored")


def test_seeds_needed_follow_the_plan_a_rerun_continues() -> None:
    """Undecided with a gain seen: the seeds needed are a look of this race's plan (a rerun
    continues to it) when the plan has the power, else a new plan's size."""
    plan = Plan(seeds_for_power(0.15, 0.3, 20, 0.05), 20)  # 120 seeds: 6 looks of 20
    rng = np.random.default_rng(4)
    current = list(rng.random(20) < 0.5)
    better = [True if not c and i % 3 == 0 else c for i, c in enumerate(current)]  # 3 won, 0 lost
    race = UnitRace([Racer(("a", "0"), 0), Racer(("a", "1"), 1)], plan)
    advance(race, {0: current, 1: better})
    decided = verdict(race, "budget spent")
    assert decided.verdict == UNDECIDED and decided.within_plan
    looks = plan.looks_for(3 / 20, 3 / 20)
    assert looks is not None and decided.seeds_needed == looks * plan.block <= plan.seeds
    assert decided.detectable == pytest.approx(plan.detectable(1))
    # A gain the plan cannot reach: 2 won and 1 lost of 20 on a 40-seed plan.
    small = UnitRace([Racer(("a", "0"), 0), Racer(("a", "1"), 1)], Plan(40, 20))
    now = [i % 2 == 0 for i in range(20)]
    new = [True if i in (1, 3) else (False if i == 2 else v) for i, v in enumerate(now)]
    advance(small, {0: now, 1: new})
    decided = verdict(small, "budget spent")
    assert decided.verdict == UNDECIDED and not decided.within_plan
    assert decided.seeds_needed == seeds_for_power(0.05, 0.15, 20, 0.05) > 40


def test_confirmed_ties_stop_and_pick_the_fewest_changes() -> None:
    """Two challengers confirmed at the same look with the same rate: the race stops there
    and picks the one changing fewer filters from the current setting."""
    current = [i % 2 == 0 for i in range(40)]
    best = [True] * 40
    racers = [
        Racer(('["downward", 140]', '["forward", 90]'), 0),
        Racer(('["downward", 120]', '["forward", 180]'), 1),  # two changes, screened first
        Racer(('["downward", 140]', '["forward", 180]'), 2),  # one change
    ]
    race = UnitRace(racers, Plan(200, 20, challengers=2))
    while not race.stopped:
        start = race.seeds_of(race.look)
        advance(race, {k: (current if k == 0 else best)[start : start + 20] for k in range(3)})
    decided = verdict(race)
    assert decided.verdict == SWITCH and decided.chosen is racers[2]
    assert race.look < race.plan.looks  # stopped when decided, not at the plan's end


def test_no_setting_helps_names_the_dominant_cause() -> None:
    never = [False] * 40
    race = UnitRace([Racer(("a", str(k)), k) for k in range(3)], Plan(200, 20, challengers=2))
    while not race.stopped:
        advance(race, {k: never[:20] for k in range(3)})
    assert race.stopped == STOP_FLOOR and verdict(race).verdict == NO_SETTING_HELPS
    rows = [
        {"valid": False, "failure_reason": "plan_failed", "failure_stage": "plan:lift"}
    ] * 38 + [{"valid": False, "success": True, "invalid_reason": "table_penetration"}] * 2
    text = cause_sentence(rows, "valid")
    assert text.startswith("plan_failed at plan:lift in 38/40: ") and "reach" in text


def test_keep_needs_the_gain_rejected_not_one_look() -> None:
    """Equal settings keep only once a target gain is rejected at the race's level."""
    rng = np.random.default_rng(0)
    same = list(rng.random(400) < 0.7)
    race = _scalar_race(np.asarray([same, same]), Plan(400, 20))
    assert verdict(race).verdict == KEEP and race.look >= 2


@pytest.mark.parametrize("text", ["0", "-3", "0s", "-5s", "abc", "1.5", "nans", "infs", ""])
def test_budget_refuses_garbage(text: str) -> None:
    with pytest.raises(HarnessError, match="--budget"):
        Budget.parse(text)


def test_budget_bounds_the_race_episodes() -> None:
    budget = Budget.parse("30")
    assert not budget.allows(0, 0.0, 40, 1.0)  # a round of 40 does not fit in 30
    assert budget.allows(0, 0.0, 30, 1.0) and not budget.allows(1, 0.0, 30, 1.0)
    assert not Budget.parse("100s").allows(0, 80.0, 30, 1.0)


@pytest.mark.parametrize(
    ("text", "key"),
    [
        ("{not json", None),
        ('["a"]', None),
        ('{"block": "twenty"}', "block"),
        ('{"top": 0}', "top"),
        ('{"blok": 20}', "blok"),
        ('{"plans": {"u": {"seeds": 10}}}', "plans"),
        (
            '{"plans": {"u": {"seeds": 9, "block": 3, "discordance": 0.3, "rate": 0.5, '
            '"challengers": 7}}}',
            "plans",
        ),
    ],
)
def test_analyse_refuses_a_garbage_tune_json(tmp_path: Path, text: str, key: str | None) -> None:
    from harness.tuning.run import OPTIONS_FILE, analyse

    (tmp_path / OPTIONS_FILE).write_text(text, encoding="utf-8")
    with pytest.raises(HarnessError) as error:
        analyse(tmp_path)
    message = str(error.value)
    assert str(tmp_path / OPTIONS_FILE) in message and "\n" not in message
    if key:
        assert repr(key) in message


def test_the_budget_line_states_the_looks_the_race_will_run() -> None:
    """Two units racing 4 settings each, blocks of 72 and 20 seeds, ``--budget 1600``: a round
    is 4 x 72 + 4 x 20 = 368 episodes and runs only when all of it fits, so both units get 4
    looks (the race's own ``Budget.allows``, stepped here); the up-front line says so for each
    (sharing the budget evenly per seed said 2 looks for the first and 10 for the second)."""
    from harness.tuning.decide import Racer, UnitRace
    from harness.tuning.options import TuneOptions
    from harness.tuning.planning import plan_lines
    from harness.tuning.race import Budget, Unit

    units = [
        Unit(f"task{k}", "{}", UnitRace([Racer(("a", str(r)), r) for r in range(4)],
                                      Plan(block * 50, block, challengers=3)))
        for k, block in enumerate((72, 20))
    ]  # fmt: skip
    budget, episodes, rounds = Budget.parse("1600"), 0, 0
    per_round = sum(u.race.plan.block * len(u.race.racers) for u in units)
    while budget.allows(episodes, 0.0, per_round, 0.0):
        episodes, rounds = episodes + per_round, rounds + 1
    assert rounds == 4
    names = {(u.task, u.context): {"robot": u.task, "arm": "left", "object": "cube"} for u in units}
    lines = plan_lines(units, names, TuneOptions(budget="1600", seconds_each=0.1))
    for unit, line in zip(units, lines, strict=True):
        assert f"allows at least {rounds} looks ({rounds * unit.race.plan.block} seeds)" in line


def test_each_race_round_reports_its_pace_and_what_the_rest_costs_at_it() -> None:
    """After a round the tune says how long it took and the most the running races can still
    ask for at that pace: a running unit's unraced seeds times its live racers; a stopped unit
    asks for nothing."""
    from harness.tuning.race import Unit, episodes_left, pace_line

    plan = Plan(100, 20)  # 5 looks of 20 seeds
    running = UnitRace([Racer(("a", str(k)), k) for k in range(3)], plan, look=2)
    running.racers[2].alive = False  # two racers left, 60 seeds each to go
    stopped = UnitRace([Racer(("a", "0"), 0), Racer(("a", "1"), 1)], plan, look=1)
    stopped.stopped = "confirmed"
    units = [Unit("t", "{}", running), Unit("t", '{"o": 1}', stopped)]
    assert episodes_left(units) == 120
    assert pace_line(1, 7012, 182.0, 14024) == (
        "race round 1: 7,012 episodes in 3.0 min; the races still running ask for at most "
        "14,024 more: at this pace up to 6.1 min"
    )
    assert pace_line(3, 40, 12.0, 0) == "race round 3: 40 episodes in 12 s; no race asks for more"
