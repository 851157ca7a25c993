"""The tune's screening: per unit (robot, arm, object), the success map of the grid on the
screening seeds, the few best settings that go on to the race, and the neighbour check.

A *setting* is the pair (approach filter, facing filter) of a grid point, as the JSON of its
point's ``pick.approach_filter`` / ``pick.facing_filter`` values. A *unit* is one task and one
value of the sweep's other axes (``object.mesh``, ...): settings are chosen per object. The
screening only *selects*; its rates are never the evidence (the screening maximum is biased up
by the selection). ``ok`` is the chosen objective: the validity verdict (default) or the
reference success; the reference success is kept beside it.
"""

from __future__ import annotations

import json
from typing import Any

import pandas as pd

from harness.config import SweepConfig
from harness.errors import HarnessError
from harness.report.frames import column, frame_of
from harness.report.stats import wilson_interval
from harness.runs.expansion import sweep_points
from harness.tuning.grid import APPROACH_KEY, FACING_KEY

SETTING = ["approach", "facing"]
UNIT = ["task", "context"]
OBJECTIVES = ("valid", "reference")
ISOLATION_DROP = 0.25  # a neighbour this far below the winner's screening rate is "poor" (chosen)


def filter_label(text: str) -> str:
    """``'["downward", 140.0]'`` -> ``downward 140``; a band -> ``downward 90-120``."""
    value = json.loads(text) if text else None
    if not value:
        return "none"
    direction, *angles = value
    return f"{direction} {'-'.join(f'{a:g}' for a in angles)}"


def point_parts(point: dict[str, Any]) -> tuple[str, str, str]:
    """(approach JSON, facing JSON, context JSON of the point's other axes)."""
    others = {k: v for k, v in point.items() if k not in (APPROACH_KEY, FACING_KEY)}
    return (
        json.dumps(point.get(APPROACH_KEY)),
        json.dumps(point.get(FACING_KEY)),
        json.dumps(others, sort_keys=True),
    )


def check_validity_ran(rated: pd.DataFrame) -> None:
    """Refuse the valid objective on episodes run without the validity phase (``valid`` False
    with no ``invalid_reason``: ``validity: off``, e.g. a tune run with ``--objective
    reference``, which switches the phase off): every setting would rate 0."""
    skipped = ~column(rated, "valid").astype(bool) & (
        column(rated, "invalid_reason").astype(str) == ""
    )
    if bool(skipped.any()):
        raise HarnessError(
            f"objective valid: {int(skipped.sum())} of {len(rated)} episodes ran without the "
            "validity phase (validity off; a tune with --objective reference skips it); decide "
            "them with --objective reference, or run the tune again with --objective valid into "
            "a new --out"
        )


def settings_frame(frame: pd.DataFrame, sweep: SweepConfig, objective: str) -> pd.DataFrame:
    """One row per rated episode: unit and setting columns, ``ok`` (the objective),
    ``reference`` (the reference success), ``fallback`` (the filter kept nothing)."""
    if objective not in OBJECTIVES:
        raise HarnessError(f"objective {objective!r}: expected one of {', '.join(OBJECTIVES)}")
    if "param." + APPROACH_KEY not in frame.columns:
        raise HarnessError(f"not a tune run: the episodes have no param.{APPROACH_KEY} column")
    rated = frame_of(frame[column(frame, "failure_reason") != "error"])
    if objective == "valid":
        check_validity_ran(rated)
    parts = [point_parts(p) for p in sweep_points(sweep)]
    ids = column(rated, "point_id").astype(int)
    outcome = column(rated, "filter_outcome") if "filter_outcome" in rated else ""
    return pd.DataFrame(
        {
            "robot": column(rated, "robot"),
            "arm": column(rated, "arm"),
            "object": column(rated, "object"),
            "task": column(rated, "task"),
            "context": [parts[i][2] for i in ids],
            "seed": column(rated, "seed"),
            "episode_index": column(rated, "episode_index"),
            "point_id": ids,
            "approach": [parts[i][0] for i in ids],
            "facing": [parts[i][1] for i in ids],
            "ok": column(rated, "valid" if objective == "valid" else "success").astype(bool),
            "reference": column(rated, "success").astype(bool),
            "fallback": pd.Series(outcome, index=rated.index).astype(str) == "fallback",
        }
    )


def merge_passes(first: pd.DataFrame, later: pd.DataFrame) -> pd.DataFrame:
    """The settings frames of two screening passes as one: ``later``'s rows of a setting the
    first pass already screened (the same filters by what they keep, on the same seeds) are
    dropped, so no seed counts twice; its grid order follows the first pass's."""
    from harness.tuning.grid import filter_key

    def keys(frame: pd.DataFrame) -> pd.Series:
        return pd.Series(
            [
                json.dumps([t, c, filter_key(json.loads(a)), filter_key(json.loads(f))])
                for t, c, a, f in zip(
                    frame["task"], frame["context"], frame["approach"], frame["facing"], strict=True
                )
            ],
            index=frame.index,
            dtype=object,
        )

    seen = set(keys(first))
    fresh = frame_of(later[~keys(later).isin(seen)]).copy()
    offset = int(column(first, "point_id").to_numpy().max()) + 1 if len(first) else 0
    fresh["point_id"] = column(fresh, "point_id") + offset
    return frame_of(pd.concat([first, fresh], ignore_index=True))


def success_map(settings: pd.DataFrame) -> pd.DataFrame:
    """Per unit and setting: n, successes, rate, Wilson bounds, the reference rate beside it,
    fallback episodes and the grid order."""
    by = ["robot", "arm", "object", *UNIT, *SETTING]
    table = (
        settings.groupby(by, sort=False)
        .agg(
            n=("ok", "size"),
            successes=("ok", "sum"),
            reference_successes=("reference", "sum"),
            fallbacks=("fallback", "sum"),
            order=("point_id", "min"),
        )
        .reset_index()
    )
    bounds = [
        wilson_interval(int(k), int(n)) for k, n in zip(table["successes"], table["n"], strict=True)
    ]
    table["rate"] = table["successes"] / table["n"]
    table["lo"] = [b[0] for b in bounds]
    table["hi"] = [b[1] for b in bounds]
    table["reference_rate"] = table["reference_successes"] / table["n"]
    return table


def ranked(unit_map: pd.DataFrame, current: tuple[str, str]) -> pd.DataFrame:
    """One unit's settings, best first: objective successes, reference successes, the current
    setting first among equals, then grid order. Fallback settings are left out."""
    table = unit_map.assign(
        is_current=(unit_map["approach"] == current[0]) & (unit_map["facing"] == current[1])
    )
    table = frame_of(table[(column(table, "fallbacks") == 0) | column(table, "is_current")])
    return table.sort_values(
        ["successes", "reference_successes", "is_current", "order"],
        ascending=[False, False, False, True],
        kind="stable",
    ).reset_index(drop=True)


def challengers(
    unit_map: pd.DataFrame, current: tuple[str, str], top: int
) -> list[tuple[str, str]]:
    """The ``top`` best non-fallback settings of the screening other than the current one."""
    table = ranked(unit_map, current)
    table = frame_of(table[~column(table, "is_current")])
    return [(str(a), str(f)) for a, f in zip(table["approach"], table["facing"], strict=True)][:top]


def axis_order(values: list[str]) -> list[str]:
    """Filter JSONs sorted as the heatmap shows them: per direction (forward, backward, upward,
    downward), single angles then bands, each ascending; no filter last."""
    from harness.tuning.grid import DIRECTIONS

    def rank(text: str) -> tuple[int, int, int, list[float]]:
        value = json.loads(text) if text else None
        if not value:
            return 1, 0, 0, []
        order = DIRECTIONS.index(value[0]) if value[0] in DIRECTIONS else len(DIRECTIONS)
        return 0, order, len(value) - 2, sorted(float(a) for a in value[1:])

    return sorted(set(values), key=rank)


def isolated(unit_map: pd.DataFrame, setting: tuple[str, str]) -> bool:
    """True when every grid neighbour of ``setting`` (one step along either axis of the map)
    screened at least ``ISOLATION_DROP`` below it: a peak that may be noise."""
    rates = {
        (str(a), str(f)): float(r)
        for a, f, r in zip(unit_map["approach"], unit_map["facing"], unit_map["rate"], strict=True)
    }
    rows, cols = axis_order(list(unit_map["approach"])), axis_order(list(unit_map["facing"]))
    if setting not in rates:
        return False
    i, j = rows.index(setting[0]), cols.index(setting[1])
    cells = [(i + di, j + dj) for di, dj in ((-1, 0), (1, 0), (0, -1), (0, 1))]
    near = [
        rates[(rows[a], cols[b])]
        for a, b in cells
        if 0 <= a < len(rows) and 0 <= b < len(cols) and (rows[a], cols[b]) in rates
    ]
    return bool(near) and all(r <= rates[setting] - ISOLATION_DROP for r in near)
