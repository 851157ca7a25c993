"""The comparison in a sweep's recording: one labelled series per robot, arm, object and setting.

Each series is the running objective rate of one setting over its episodes (episode k: the
share of its first k rated episodes that met the objective, ``valid`` or ``reference``), on the
``episode`` timeline; its last value is the setting's rate, and how it settles shows how sure
that is. Series live under ``/compare/<robot>/<arm>/<object>/<setting>`` and carry their name
(``SeriesLines(names=...)``), so one time-series view per robot, arm and object compares its
settings with a legend naming each. A tune's grid can hold dozens of settings per object: the
``MAX_SERIES`` best by final rate are drawn and the view's name says how many were left out.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from typing import Any, cast

import numpy as np
import pandas as pd

TIMELINE = "episode"
# One colour per setting in every panel (matplotlib's tab10, RGB): the same setting reads the
# same in each robot, arm and object's view; settings take colours in sorted order.
PALETTE: tuple[tuple[int, int, int], ...] = (
    (31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189),
    (140, 86, 75), (227, 119, 194), (127, 127, 127), (188, 189, 34), (23, 190, 207),
)  # fmt: skip
# The rate axis runs past 1 so the legend, in its top-left corner, sits above every rate.
AXIS_TOP = 1.6
MAX_SERIES = 10  # settings drawn per robot, arm and object (best final rate first)
UNIT_KEYS = ("robot", "arm", "object")
UNRATED = ("error", "not_runnable")  # harness.failures.UNRATED_REASONS: never in a rate


@dataclass(frozen=True)
class Series:
    """One setting's running rate: its entity, legend name and values per episode."""

    entity: str
    name: str
    rates: np.ndarray  # running objective rate after 1..n episodes
    final: float
    setting: str = ""  # the setting's label, the same in every unit (its colour's key)


@dataclass(frozen=True)
class Unit:
    """One robot, arm and object: its view's origin and name, and its series."""

    origin: str
    name: str
    series: list[Series]


def column(frame: pd.DataFrame, name: str) -> pd.Series:
    """One column (viz does not import the report package, which imports viz)."""
    return cast(pd.Series, frame[name])


def frame_of(value: Any) -> pd.DataFrame:
    return cast(pd.DataFrame, value)


def _value(text: Any) -> str:
    """A parameter value for a legend: ``["downward", 120]`` -> ``downward 120``."""
    if isinstance(text, float) and np.isnan(text):
        return ""
    if isinstance(text, str) and text.startswith("["):
        try:
            parsed = json.loads(text)
        except json.JSONDecodeError:
            return text
        return " ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in parsed)
    if isinstance(text, float):
        return f"{text:g}"
    return str(text)


def _part(text: str) -> str:
    """An entity path part: letters, digits, ``.``, ``-`` and ``_`` only."""
    return re.sub(r"[^A-Za-z0-9._-]+", "_", text).strip("_") or "_"


def _settings(group: pd.DataFrame) -> list[str]:
    """The ``param.*`` columns that vary within one robot, arm and object."""
    params = [str(c) for c in group.columns if str(c).startswith("param.")]
    return [c for c in params if column(group, c).astype(str).nunique() > 1]


def _label(row: Any, settings: list[str]) -> str:
    if not settings:
        return "the task's setting"
    return ", ".join(f"{c.split('.')[-1]}={_value(row[c])}" for c in settings)


def comparison_units(episodes: pd.DataFrame, objective: str) -> list[Unit]:
    """The series per robot, arm and object of a run's episodes (see the module docstring)."""
    verdict = "valid" if objective == "valid" and "valid" in episodes else "success"
    if verdict not in episodes or any(k not in episodes for k in UNIT_KEYS):
        return []
    reasons = (
        column(episodes, "failure_reason").fillna("").astype(str)
        if "failure_reason" in episodes
        else pd.Series("", index=episodes.index)
    )
    rated = frame_of(episodes[~reasons.isin(UNRATED)])
    units = []
    for key, found in rated.groupby(list(UNIT_KEYS), sort=True):
        robot, arm, obj = (str(v) for v in key)  # type: ignore[union-attr]
        group = frame_of(found)
        settings = _settings(group)
        origin = "/compare/" + "/".join(_part(v) for v in (robot, arm, obj))
        order = "episode_index" if "episode_index" in group else "seed"
        series = []
        groups = group.groupby(settings, sort=False) if settings else [(None, group)]
        for _, selected in groups:
            rows = frame_of(selected)
            rows = rows.sort_values(by=order, kind="stable") if order in rows else rows
            # a CSV column of True/False with blanks reads as text: compare the text
            met = column(rows, verdict).astype(str).str.lower().eq("true").to_numpy()
            rates = np.cumsum(met) / np.arange(1, len(met) + 1)
            label = _label(rows.iloc[0], settings)
            entity = f"{origin}/{_part(label)}"
            series.append(Series(entity, f"{label} ({objective})", rates, rates[-1], label))
        series.sort(key=lambda s: -s.final)
        left_out = max(0, len(series) - MAX_SERIES)
        # Short enough to show whole above a panel of a grid (the settings are in the legend).
        name = f"{robot} {arm} {obj} ({objective})"
        name += f", best {MAX_SERIES} of {len(series)}" if left_out else ""
        units.append(Unit(origin, name, series[:MAX_SERIES]))
    return units


def setting_colors(units: list[Unit]) -> dict[str, tuple[int, int, int]]:
    """One colour per setting label over every unit (``PALETTE``, in sorted label order)."""
    labels = sorted({series.setting for unit in units for series in unit.series})
    return {label: PALETTE[k % len(PALETTE)] for k, label in enumerate(labels)}


def log_comparison(rec: Any, units: list[Unit]) -> None:
    """Each series: its name and its setting's colour once (static), then its running rate on
    the episode timeline."""
    import rerun as rr

    colors = setting_colors(units)
    for unit in units:
        for series in unit.series:
            color = colors.get(series.setting, PALETTE[0])
            lines = rr.SeriesLines(names=[series.name], colors=[color])
            rec.log(series.entity, lines, static=True)
            steps = np.arange(1, len(series.rates) + 1, dtype=np.int64)
            rec.send_columns(
                series.entity,
                indexes=[rr.TimeColumn(TIMELINE, sequence=steps)],
                columns=rr.Scalars.columns(scalars=series.rates.astype(float)),
            )


def comparison_views(units: list[Unit]) -> list[Any]:
    """One time-series view per robot, arm and object: the legend in the top-left corner above
    the rates (the axis runs to ``AXIS_TOP``, past the highest rate 1), not over the data."""
    import rerun.blueprint as rrb

    return [
        rrb.TimeSeriesView(
            name=unit.name,
            origin=unit.origin,
            plot_legend=rrb.PlotLegend(corner=rrb.components.Corner2D.LeftTop, visible=True),
            axis_y=rrb.ScalarAxis(range=(0.0, AXIS_TOP)),
        )
        for unit in units
    ]
