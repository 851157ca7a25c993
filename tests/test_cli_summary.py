"""The terminal's per-point table leads with the objective (issue 56).

The fixture run of tests/test_report_answer.py: fr3's point 2 (downward 140, pre-grasp 0.05) is
5/5 by the reference check but 1/5 valid (four fingers in the table), so a table that led with
the reference rate or counted only failure reasons would show it as a clean 100%.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd
from rich.console import Console
from test_report_answer import validity_run

from harness.commands.summary_table import summary_table
from harness.report import build_report


def rendered(summary: pd.DataFrame, objective: str, width: int = 80) -> list[str]:
    console = Console(width=width, record=True, color_system=None)
    console.print(summary_table(summary, objective))
    return console.export_text().splitlines()


def row_of(lines: list[str], start: str, holding: str) -> str:
    return next(line for line in lines if line.startswith(start) and holding in line)


def fixture_summary(tmp_path: Path) -> pd.DataFrame:
    paths = build_report(validity_run(tmp_path / "run"))
    return pd.read_csv(paths.summary_csv)


def test_the_table_leads_with_valid_and_counts_why_the_rest_are_not_valid(
    tmp_path: Path,
) -> None:
    lines = rendered(fixture_summary(tmp_path), "valid")
    names = lines[3]  # the header's last line (keys broken after an underscore above it)
    assert names.index("valid") < names.index("95% CI") < names.index("not valid")
    assert names.index("not valid") < names.rindex("success")
    assert lines[2].rstrip().endswith("reference")  # the other rate, named: reference success
    point_2 = row_of(lines, "downward 140  0.05", "1/5")
    assert "1/5 20%" in point_2 and "0.04–0.62" in point_2  # valid first, its interval whole
    assert "table_penetration 4" in point_2  # the 4 invalid episodes, named and counted
    assert point_2.rstrip().endswith("5/5 100%")  # the reference rate last


def test_the_table_fits_80_columns_without_cutting_a_setting_or_an_interval(
    tmp_path: Path,
) -> None:
    summary = fixture_summary(tmp_path)
    for objective in ("valid", "reference"):
        lines = rendered(summary, objective)
        assert max(len(line) for line in lines) <= 80
        text = "\n".join(lines)
        assert "…" not in text
        for setting in ("downward 140", "downward 120", "0.05"):
            assert setting in text
        for row in summary.itertuples():
            assert f"{row.wilson_lo:.2f}–{row.wilson_hi:.2f}" in text
            assert f"{row.valid_ci_low:.2f}–{row.valid_ci_high:.2f}" in text
        units = [line for line in lines if line.startswith(("fr3", "split_aloha"))]
        assert len(units) == 3  # a unit's name once, above its settings


def test_under_the_reference_objective_success_leads_and_valid_is_named(tmp_path: Path) -> None:
    lines = rendered(fixture_summary(tmp_path), "reference")
    names = lines[3]
    assert names.index("success") < names.index("not success") < names.rindex("valid")
    point_2 = row_of(lines, "downward 140  0.05", "5/5")
    assert point_2.index("5/5 100%") < point_2.index("1/5 20%")
