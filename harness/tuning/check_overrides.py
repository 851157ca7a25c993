"""A template tune's confirmed overrides as check units (``harness tune --check``)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pandas as pd

from harness.errors import HarnessError
from harness.report.frames import frame_of
from harness.tuning.decide import SWITCH


def override_units(
    tune_dir: Path, decisions: pd.DataFrame, unit_type: Any, check_setting: Any
) -> list[Any]:
    """A template tune's confirmed overrides (``tune/objects.csv``): each object's own setting
    against its group's template, checked as a switch is (``role`` "override")."""
    path = tune_dir / "tune" / "objects.csv"
    if not path.is_file():
        return []
    columns = ("group", "context", "task", "exception", "own_best_approach", "own_best_facing")
    try:
        table = pd.read_csv(path, dtype={"task": str, "context": str, "group": str})
    except pd.errors.EmptyDataError:  # a tune without template groups: no objects
        return []
    except (OSError, UnicodeDecodeError, ValueError, pd.errors.ParserError) as error:
        raise HarnessError(f"{path}: not a tune's objects.csv ({error})") from None
    if table.empty:
        return []
    missing = [c for c in columns if c not in table.columns]
    if missing:
        raise HarnessError(f"{path}: not a tune's objects.csv: column {missing[0]!r} is missing")
    units = []
    for row in frame_of(table[table["exception"] == "override"]).to_dict("records"):
        group = decisions[decisions["task"] == str(row["group"])]
        if group.empty:
            raise HarnessError(f"{path}: group {row['group']!r} is not in decisions.csv")
        decided = group.iloc[0].to_dict()
        template = (
            (str(decided["approach"]), str(decided["facing"]))
            if decided["verdict"] == SWITCH
            else (str(decided["current_approach"]), str(decided["current_facing"]))
        )
        override = (str(row["own_best_approach"]), str(row["own_best_facing"]))
        for setting in (template, override):
            check_setting(setting, tune_dir, str(row["task"]))
        names = {
            "robot": str(decided["robot"]),
            "arm": str(decided["arm"]),
            "object": str(row["task"]),
        }
        units.append(
            unit_type(
                str(row["task"]),
                str(row["context"]),
                names,
                SWITCH,
                template,
                override,
                "override",
                (math.nan, math.nan),
            )
        )
    return units
