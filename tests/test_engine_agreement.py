"""The per-point agreement of two runs of one sweep (``harness.benchmarks.agreement``)."""

from __future__ import annotations

import pandas as pd
import pytest

from harness.benchmarks.agreement import per_point, wilson


def _rows(valid: list[bool], reasons: list[str], task: str = "t") -> pd.DataFrame:
    n = len(valid)
    return pd.DataFrame(
        {
            "task": [task] * n,
            "point": ["a"] * (n // 2) + ["b"] * (n - n // 2),
            "episode_id": [f"e{k % (n // 2)}" for k in range(n)],
            "sim_steps": [100] * (n - 1) + [0],  # the last one never executed
            "success": [True] * n,
            "failure_reason": reasons,
            "valid": valid,
        }
    )


def test_wilson_matches_the_textbook_interval() -> None:
    low, high = wilson(8, 10)  # Wilson (1927) for 8/10: 0.490-0.943
    assert low == pytest.approx(0.4902, abs=1e-4) and high == pytest.approx(0.9433, abs=1e-4)
    assert wilson(0, 0) == (0.0, 1.0)


def test_a_gap_at_one_point_shows_although_the_pool_agrees_more() -> None:
    cpu = _rows([True] * 20 + [False] * 20, [""] * 40)
    gpu = _rows([True] * 20 + [True] * 10 + [False] * 10, [""] * 40)
    table = per_point(cpu, gpu).set_index("point")
    assert table.loc["t a", "valid_agree"] == 1.0 and table.loc["t a", "valid_inside"]
    assert table.loc["t b", "executed"] == 19  # its last episode never executed
    assert table.loc["t b", "valid_agree"] == pytest.approx(9 / 19)
    assert not table.loc["t b", "valid_inside"]
    assert table.loc["all", "n"] == 40 and table.loc["all", "valid_gpu"] == 0.75


def test_the_same_point_of_two_tasks_is_two_points() -> None:
    """The demo's points repeat over its arms: each (task, point) is its own line, each task
    has its pooled line, and a gap on one arm is not averaged away by the other."""
    agree = _rows([True] * 20 + [False] * 20, [""] * 40, task="fr3")
    cpu = pd.concat([agree, _rows([True] * 40, [""] * 40, task="aloha")])
    gpu = pd.concat([agree, _rows([True] * 20 + [False] * 20, [""] * 40, task="aloha")])
    table = per_point(cpu, gpu).set_index("point")
    assert table.loc["fr3 b", "valid_agree"] == 1.0 and table.loc["aloha a", "valid_agree"] == 1.0
    assert table.loc["aloha b", "valid_agree"] == 0.0 and not table.loc["aloha b", "valid_inside"]
    assert table.loc["aloha all", "n"] == table.loc["fr3 all", "n"] == 40
    assert table.loc["all", "n"] == 80
