"""The per-point agreement of two runs of one sweep (``harness.benchmarks.agreement``)."""

from __future__ import annotations

import pandas as pd
import pytest

from harness.benchmarks.agreement import per_point, wilson


def _rows(valid: list[bool], reasons: list[str]) -> pd.DataFrame:
    n = len(valid)
    return pd.DataFrame(
        {
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
    assert table.loc["a", "valid_agree"] == 1.0 and table.loc["a", "valid_inside"]
    assert table.loc["b", "executed"] == 19  # its last episode never executed
    assert table.loc["b", "valid_agree"] == pytest.approx(9 / 19)
    assert not table.loc["b", "valid_inside"]
    assert table.loc["all", "n"] == 40 and table.loc["all", "valid_gpu"] == 0.75
