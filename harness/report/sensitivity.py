"""The sensitivity section: how each rate and each best setting moves over a swept unknown.

A physical value without a primary source (a robot.yaml ``sources`` entry marked "chosen", e.g.
the Piper's grip force, pad friction, the Split ALOHA mounting height; the object's friction)
is swept as an axis instead of trusted. For every such axis in a run, and for every robot,
arm and object, this section shows per value of the axis the reference and the valid rate of
each setting (the other swept keys), and labels what the answer depends on:

- ``moves``: a rate's 95% Wilson intervals at two values of the unknown do not overlap, so
  the number reported at the default is a statement about the chosen value;
- ``best setting flips``: the setting with the highest Wilson lower bound (the report's "best
  setting" rule) is not the same at every value of the unknown, so the conclusion "use X"
  does not hold over the range;
- ``stable`` otherwise (within the intervals this range of the unknown changes nothing).

One table per unknown axis; rows are (robot, arm, object, setting). Pure pandas over the
summary; the run's episodes are not read again.
"""

from __future__ import annotations

import json
from functools import cache

import pandas as pd

from harness.report.labels import format_value, point_label
from harness.report.sections import Table
from harness.report.tables import GROUP_KEY, pooled
from harness.row import PARAM_PREFIX, param_columns

# Task keys that sweep a value with no primary source, beyond those the bundled robots'
# robot.yaml ``sources`` name: the object's contact friction and mass (the reference reads them
# from its USDs, which a mesh path does not carry) and the validity's chosen rotation bound.
OBJECT_UNKNOWNS = ("object.friction", "object.mass", "pick.max_slip_rotation")
FLIP = "best setting flips"
MOVES = "moves"
STABLE = "stable"


@cache
def unknown_axes() -> frozenset[str]:
    """Task keys that sweep an unsourced physical value: the axes the bundled robots'
    ``sources`` name for their "chosen" values, and ``OBJECT_UNKNOWNS``."""
    from harness.config.robot_registry import available_robots
    from harness.robots.facts import robot_file

    axes: set[str] = set(OBJECT_UNKNOWNS)
    for name in available_robots():
        axes.update(axis for axis in robot_file(name).unsourced().values() if axis)
    return frozenset(axes)


def sensitivity_axes(summary: pd.DataFrame, unknowns: frozenset[str] | None = None) -> list[str]:
    """The ``param.*`` columns of ``summary`` that sweep an unknown and take 2+ values."""
    names = unknown_axes() if unknowns is None else unknowns
    return [
        column
        for column in param_columns(summary.columns)
        if _unknown(column.removeprefix(PARAM_PREFIX), names) and _distinct(summary, column) > 1
    ]


def _distinct(frame: pd.DataFrame, column: str) -> int:
    """How many distinct values ``column`` of ``frame`` takes (NaN not counted)."""
    return int(pd.Series(frame[column]).nunique())


def _varies_within_units(summary: pd.DataFrame, column: str) -> bool:
    """``column`` takes 2+ values within some robot, arm and object (a swept setting)."""
    counts = pd.Series(summary.groupby(GROUP_KEY)[column].nunique())
    return bool((counts > 1).any())


def _unknown(key: str, names: frozenset[str]) -> bool:
    """``key`` sweeps one of ``names`` (a task's gripper keys may be spelt with or without
    their ``robot.`` prefix; a whole block such as ``robot_placement`` sweeps its keys)."""
    if key in names or key.removeprefix("robot.") in names or f"robot.{key}" in names:
        return True
    return any(name.startswith(f"{key}.") for name in names)  # a whole block, e.g. placement


def _overlap(a: tuple[float, float], b: tuple[float, float]) -> bool:
    return a[0] <= b[1] and b[0] <= a[1]


def _rate_text(successes: int, n: int) -> str:
    return f"{successes}/{n}" if n else "–"


def _order_key(value: object) -> tuple[int, float | str]:
    """Numeric values in numeric order, others (lists as JSON text) after them."""
    try:
        return 0, float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return 1, json.dumps(value) if not isinstance(value, str) else value


def judge(per_value: pd.DataFrame, axis: str, settings: list[str]) -> dict[tuple, str]:
    """The label of each setting's row in one (robot, arm, object) group, and of the group's
    best setting: ``FLIP`` on every row when the best setting differs across the axis values,
    else ``MOVES`` for a setting whose reference or valid intervals at two values do not
    overlap, else ``STABLE``. Keys: the settings' values as a tuple (``()`` without settings)."""
    labels: dict[tuple, str] = {}
    best_by_value: set[tuple] = set()
    for _, at_value in per_value.groupby(axis, sort=False, dropna=False):
        ranked = at_value.sort_values(["wilson_lo", "rate", "n"], ascending=False, kind="stable")
        best_by_value.add(tuple(ranked.iloc[0][settings]) if settings else ())
    flips = len(best_by_value) > 1
    keys = per_value.groupby(settings, sort=False, dropna=False) if settings else [((), per_value)]
    for key, rows in keys:
        key_tuple = tuple(key) if isinstance(key, tuple) else (key,)
        if flips:
            labels[key_tuple if settings else ()] = FLIP
            continue
        moved = False
        for lo, hi in (("wilson_lo", "wilson_hi"), ("valid_ci_low", "valid_ci_high")):
            if lo not in rows:
                continue
            spans = [
                (float(r[lo]), float(r[hi]))
                for r in rows.to_dict("records")
                if r[lo] == r[lo]  # NaN: no interval
            ]
            moved |= any(not _overlap(a, b) for a in spans for b in spans)
        labels[key_tuple if settings else ()] = MOVES if moved else STABLE
    return labels


def sensitivity_tables(
    summary: pd.DataFrame, unknowns: frozenset[str] | None = None
) -> list[Table]:
    """One table per swept unknown (see the module docstring); none when the run swept none."""
    if summary.empty:
        return []
    tables: list[Table] = []
    for axis in sensitivity_axes(summary, unknowns):
        settings = [
            c
            for c in param_columns(summary.columns)
            if c != axis and _varies_within_units(summary, c)
        ]
        per_value = pooled(summary, [*GROUP_KEY, axis, *settings])
        values = sorted(per_value[axis].dropna().unique().tolist(), key=_order_key)
        header = [
            "robot",
            "arm",
            "object",
            "setting",
            *[f"{axis.removeprefix(PARAM_PREFIX)}={format_value(v)}" for v in values],
            "answer",
        ]
        rows: list[list[str]] = []
        for key, group in per_value.groupby(GROUP_KEY, sort=True):
            robot, arm, obj = tuple(key)  # type: ignore[misc]
            labels = judge(group, axis, settings)
            setting_groups = (
                group.groupby(settings, sort=True, dropna=False) if settings else [((), group)]
            )
            for key, rows_of_setting in setting_groups:
                key_tuple = tuple(key) if isinstance(key, tuple) else (key,)
                cells = []
                for value in values:
                    at = rows_of_setting[rows_of_setting[axis] == value]
                    if at.empty:
                        cells.append("")
                        continue
                    row = at.iloc[0]
                    valid = (
                        f" · valid {_rate_text(int(row['valid']), int(row['n_judged']))}"
                        if "n_judged" in row and int(row["n_judged"])
                        else ""
                    )
                    cells.append(f"{_rate_text(int(row['successes']), int(row['n']))}{valid}")
                setting = point_label(rows_of_setting.iloc[0], settings) if settings else "–"
                label = labels.get(key_tuple if settings else (), STABLE)
                rows.append([str(robot), str(arm), str(obj), setting, *cells, label])
        name = axis.removeprefix(PARAM_PREFIX)
        tables.append(
            Table(
                f"Sensitivity to {name} (no primary source)",
                header,
                rows,
                note=(
                    f"{name} has no primary source (robot.yaml sources), so the run swept it. "
                    "Cells: reference successes / n · valid / judged, per value. Answer: "
                    f"'{FLIP}' when the setting with the best Wilson lower bound is not the same "
                    f"at every value (the recommendation depends on the unknown); '{MOVES}' "
                    "when a rate's 95% Wilson intervals at two values do not overlap; "
                    f"'{STABLE}' otherwise."
                ),
            )
        )
    return tables
