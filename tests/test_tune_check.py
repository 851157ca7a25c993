"""``harness tune --check``: a tune's decisions tested on fresh paired seeds.

Fast tests: the paired statistics on hand counts (exact McNemar p, Holm's order and values
against statsmodels), the verdict rules, the refusal of a sweep seed the tune used and of a
missing or garbage ``decisions.csv``. One slow test checks a tiny real tune on fresh seeds and
asserts that ``check.csv``'s counts equal the stored episodes of the check's run directory.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from statsmodels.stats.multitest import multipletests

from harness.cli import main as cli_main
from harness.errors import HarnessError
from harness.report.tables import load_episodes
from harness.report.tune_link import check_rows
from harness.runs.executors import RunStats
from harness.tuning.check import (
    CHECK_SEED_OFFSET,
    CONFIRMED,
    CONTRADICTED,
    HELD,
    MISSED_GAIN,
    NO_CHALLENGER,
    NOT_CONFIRMED,
    CheckUnit,
    check_table,
    check_units,
    check_verdict,
    paired_stats,
    read_decisions,
    refuse_overlap,
    run_check,
    select_units,
)
from harness.tuning.decide import KEEP, SWITCH, UNDECIDED
from harness.tuning.planning import unit_key
from harness.tuning.run import TuneOptions, tune

ROOT = Path(__file__).resolve().parents[1]
FR3 = ROOT / "tasks" / "pick" / "fr3.yaml"


def _pairs(both: int, only_current: int, only_new: int, neither: int) -> tuple[list, list]:
    """Paired outcome lists (current, new) with the given 2x2 table."""
    current = [True] * both + [True] * only_current + [False] * only_new + [False] * neither
    new = [True] * both + [False] * only_current + [True] * only_new + [False] * neither
    return current, new


def test_paired_stats_give_the_exact_mcnemar_p_of_the_discordant_seeds() -> None:
    current, new = _pairs(both=30, only_current=0, only_new=10, neither=10)
    stats = paired_stats(current, new)
    assert (stats["n"], stats["current_successes"], stats["successes"]) == (50, 30, 40)
    assert (stats["only_new"], stats["only_current"]) == (10, 0)
    assert stats["p"] == pytest.approx(2 * 0.5**10)  # two-sided exact: 2 * P(B(10, 1/2) = 10)
    assert stats["gain"] == pytest.approx(0.2)
    assert stats["gain_lo"] < 0.2 < stats["gain_hi"]
    assert stats["lo"] < 0.8 < stats["hi"]
    # 7 vs 3 discordant: 2 * P(B(10, 1/2) >= 7) = 2 * 176 / 1024
    stats = paired_stats(*_pairs(both=5, only_current=3, only_new=7, neither=5))
    assert stats["p"] == pytest.approx(2 * 176 / 1024)
    assert paired_stats(*_pairs(4, 0, 0, 6))["p"] == 1.0  # no discordant seed


def _unit(verdict: str, candidate: bool = True) -> CheckUnit:
    setting = ('["downward", 90]', '["forward", 180]')
    return CheckUnit(
        "fr3_pick",
        '{"object.mesh": "cube"}',
        {"robot": "fr3", "arm": "left", "object": "cube"},
        verdict,
        ('["downward", 140]', '["forward", 90]'),
        setting if candidate else None,
        "tuned" if verdict == SWITCH else "best challenger",
        (0.6, 0.9),
    )


def test_holm_over_the_units_matches_statsmodels_and_sets_the_verdicts() -> None:
    units = [_unit(SWITCH), _unit(SWITCH), _unit(KEEP), _unit(UNDECIDED), _unit(KEEP, False)]
    outcomes = [
        _pairs(40, 0, 12, 48),  # tuned better: p = 2 / 2**12
        _pairs(40, 4, 6, 50),  # no significant difference
        _pairs(40, 0, 9, 51),  # the challenger better: a missed gain
        _pairs(40, 9, 0, 51),  # the challenger worse: the keep held
        _pairs(40, 0, 0, 60),  # no challenger: the current only
    ]
    table = check_table(units, outcomes)
    raw = table["p"].iloc[:4].tolist()
    expected = np.asarray(multipletests(raw, alpha=0.05, method="holm")[1], float).tolist()
    assert table["p_holm"].iloc[:4].tolist() == pytest.approx(expected)
    # by hand: raw 2/2**12, 2 * 386/1024, 2/2**9, 2/2**9; Holm multiplies the smallest by 4,
    # the next two by 3 and 2 (monotone: both 3 * 2/2**9), the largest by 1
    assert raw == pytest.approx([2 / 4096, 772 / 1024, 2 / 512, 2 / 512])
    assert table["p_holm"].iloc[:4].tolist() == pytest.approx(
        [8 / 4096, 772 / 1024, 6 / 512, 6 / 512]
    )
    assert math.isnan(table["p_holm"].iloc[4]) and math.isnan(table["rate"].iloc[4])
    assert table["verdict"].tolist() == [CONFIRMED, NOT_CONFIRMED, MISSED_GAIN, HELD, NO_CHALLENGER]
    # the decided setting's fresh rate (tuned 52/100 for the switch, current 40/100 for the
    # keep) against the tune's interval (0.6, 0.9): outside both
    assert table["inside_tune_interval"].tolist()[:3] == [False, False, False]
    header, rows = check_rows(table)  # the printed table: one unit label per task file
    assert len(header) == len(rows[0]) and rows[0][0] == "fr3 left cube (fr3_pick)"
    assert rows[0][5] == "+12/-0" and rows[4][4] == "-" and rows[4][7] == NO_CHALLENGER


def test_the_verdict_rules() -> None:
    assert check_verdict(SWITCH, 12, 2, 0.01) == CONFIRMED
    assert check_verdict(SWITCH, 2, 12, 0.01) == CONTRADICTED
    assert check_verdict(SWITCH, 12, 2, 0.2) == NOT_CONFIRMED
    assert check_verdict(KEEP, 12, 2, 0.01) == MISSED_GAIN
    assert check_verdict(UNDECIDED, 2, 12, 0.01) == HELD
    assert check_verdict(KEEP, 12, 2, 0.05) == HELD  # Holm p < 0.05, not <=


def test_a_seed_the_tune_used_is_refused_with_one_line(tmp_path: Path) -> None:
    seeds = {"screen": 5, "confirm": 100_005}
    for seed, which in ((5, "screening"), (100_005, "race")):
        with pytest.raises(HarnessError) as error:
            refuse_overlap(seed, seeds, tmp_path)
        message = str(error.value)
        assert "\n" not in message and f"--seed {seed}" in message and which in message
        assert str(100_005 + CHECK_SEED_OFFSET) in message
    refuse_overlap(777_777, seeds, tmp_path)  # a seed the tune never used passes


@pytest.mark.parametrize(
    "content, expected",
    [
        (None, "no decisions.csv"),
        ("\x00\x01garbage\n\x02", "column 'task' is missing"),
        ("task,context,verdict\nfr3_pick,{},keep current\n", "column 'robot' is missing"),
    ],
)
def test_a_missing_or_garbage_decisions_file_is_one_line_naming_it(
    tmp_path: Path, content: str | None, expected: str
) -> None:
    path = tmp_path / "tune" / "decisions.csv"
    if content is not None:
        path.parent.mkdir()
        path.write_text(content)
    with pytest.raises(HarnessError) as error:
        read_decisions(tmp_path)
    message = str(error.value)
    assert "\n" not in message and str(path) in message and expected in message
    with pytest.raises(HarnessError, match=r"tune\.json"):
        run_check(tmp_path)  # not a tune directory at all


@pytest.mark.slow
def test_check_of_a_tiny_real_tune_counts_the_stored_episodes(
    tmp_path: Path, capsys, monkeypatch: pytest.MonkeyPatch
) -> None:
    tune_dir = tmp_path / "tune"
    options = TuneOptions(screen_seeds=2, top=1, block=4, max_seeds=4, coarse=False)
    tune([FR3], step=90, bands=0, out=tune_dir, options=options, backend="serial")
    refused = cli_main(["tune", "--check", str(tune_dir), "--seed", "100000", "--episodes", "3"])
    message = capsys.readouterr().err.strip()
    assert refused != 0 and "race" in message and len(message.splitlines()) == 1
    check = ["tune", "--check", str(tune_dir), "--seed", "777777", "--episodes", "3"]
    with monkeypatch.context() as patch:  # Ctrl-C during the check: it decides nothing
        patch.setattr(
            "harness.tuning.race.executor_for",
            lambda *_: lambda *_args, **_kw: RunStats(interrupted=True),
        )
        assert cli_main([*check, "--workers", "1"]) == 130
    assert "decides nothing" in capsys.readouterr().out
    assert not (tune_dir / "check" / "check.csv").exists()
    assert cli_main([*check, "--workers", "1"]) == 0  # the same command continues it
    assert "fr3 left cube" in capsys.readouterr().out
    check_dir = tune_dir / "check"
    table = pd.read_csv(check_dir / "check.csv")
    columns = ["robot", "arm", "object", "tune_verdict", "tested", "n", "current_successes"]
    columns += ["successes", "only_new", "only_current", "p", "p_holm", "verdict"]
    assert {*columns, "inside_tune_interval", "tune_lo", "tune_hi"} <= set(table.columns)
    decisions = pd.read_csv(tune_dir / "tune" / "decisions.csv")
    assert len(table) == len(decisions) == 1
    row = table.iloc[0]
    assert row["verdict"] in (CONFIRMED, NOT_CONFIRMED, CONTRADICTED, HELD, MISSED_GAIN)
    episodes = load_episodes(check_dir)
    seeds = set(episodes["seed"])
    assert row["n"] == 3 and len(seeds) == 3  # 3 paired fresh seeds
    used = set(load_episodes(tune_dir / "screen")["seed"]) | set(
        load_episodes(tune_dir / "confirm")["seed"]
    )
    assert not seeds & used
    by_point = episodes.groupby("point_id")["valid"].agg(["sum", "count"])
    assert len(by_point) == 2 and by_point["count"].tolist() == [3, 3]
    counted = sorted(int(k) for k in by_point["sum"])
    assert counted == sorted([int(row["current_successes"]), int(row["successes"])])
    wins = episodes.pivot_table(index="seed", columns="point_id", values="valid", aggfunc="first")
    differ = int((wins.iloc[:, 0].astype(bool) != wins.iloc[:, 1].astype(bool)).sum())
    assert differ == row["only_new"] + row["only_current"]
    page = (tune_dir / "screen" / "report.html").read_text()
    assert "checked on fresh seeds" in page and str(row["verdict"]) in page
    # a rerun reuses every stored episode and writes the same table
    assert cli_main([*check, "--workers", "1"]) == 0
    assert len(load_episodes(check_dir)) == len(episodes)
    assert pd.read_csv(check_dir / "check.csv").equals(table)
    changed = cli_main([*check[:-1], "5"])
    assert changed != 0 and "--episodes 3" in capsys.readouterr().err


def _decision(verdict: str, approach: str = '["downward", 90.0]') -> dict[str, object]:
    return {
        "task": "fr3_pick", "context": "{}", "robot": "fr3", "arm": "left", "object": "cube",
        "verdict": verdict, "approach": approach, "facing": '["forward", 180.0]',
        "current_approach": '["downward", 140.0]', "current_facing": '["forward", 90.0]',
        "lo": 0.7, "hi": 0.9, "current_lo": 0.5, "current_hi": 0.8,
    }  # fmt: skip


def test_a_keep_is_checked_against_the_best_challenger_that_never_fell_back(
    tmp_path: Path,
) -> None:
    """Best challenger: the highest rate on the race's seeds, fallback racers excluded; its
    filters come from tune.json's plan by screening rank."""
    race = pd.DataFrame(
        {
            "task": ["fr3_pick"] * 4, "context": ["{}"] * 4,
            "current": [True, False, False, False], "screen_rank": [0, 1, 2, 3],
            "n": [20, 20, 20, 10], "successes": [10, 20, 12, 7],
            "fallback": [False, True, False, False],
        }
    )  # fmt: skip
    chosen = [["a1", "f1"], ["a2", "f2"], ['["downward", 120.0]', '["forward", 150.0]']]
    options = TuneOptions(plans={unit_key("fr3_pick", "{}"): {"challengers": chosen}})
    (unit,) = check_units(pd.DataFrame([_decision(KEEP)]), race, options, tmp_path)
    assert unit.candidate == ('["downward", 120.0]', '["forward", 150.0]')  # 7/10 beats 12/20
    assert unit.role == "best challenger" and unit.tune_interval == (0.5, 0.8)
    (switch,) = check_units(pd.DataFrame([_decision(SWITCH)]), race, options, tmp_path)
    assert switch.candidate == ('["downward", 90.0]', '["forward", 180.0]')
    assert switch.tune_interval == (0.7, 0.9)
    with pytest.raises(HarnessError) as error:
        check_units(pd.DataFrame([_decision(SWITCH, "downward 90")]), race, options, tmp_path)
    assert "decisions.csv" in str(error.value) and "'downward 90'" in str(error.value)


def test_a_check_of_named_units_tests_those_alone(tmp_path: Path) -> None:
    """``--unit 'robot arm object'``: the check keeps the named units (Holm over them alone);
    a name the tune does not have is one line listing the tune's units."""
    race = pd.DataFrame(
        {
            "task": ["fr3_pick"] * 2, "context": ["{}"] * 2, "current": [True, False],
            "screen_rank": [0, 1], "n": [20, 20], "successes": [10, 12],
            "fallback": [False, False],
        }
    )  # fmt: skip
    chosen = [['["downward", 120.0]', '["forward", 150.0]']]
    options = TuneOptions(plans={unit_key("fr3_pick", "{}"): {"challengers": chosen}})
    cube, banana = _decision(SWITCH), {**_decision(KEEP), "object": "banana"}
    units = check_units(pd.DataFrame([cube, banana]), race, options, tmp_path)
    assert select_units(units, None, tmp_path) == units
    (chosen,) = select_units(units, ["fr3 left banana"], tmp_path)
    assert chosen.names["object"] == "banana" and chosen.verdict == KEEP
    with pytest.raises(HarnessError) as error:
        select_units(units, ["fr3 left mug"], tmp_path)
    message = str(error.value)
    assert "\n" not in message and "'fr3 left mug'" in message
    assert "fr3 left cube, fr3 left banana" in message
    assert cli_main(["tune", "--unit", "fr3 left cube", str(tmp_path / "x.yaml")]) != 0
