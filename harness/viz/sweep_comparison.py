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
            series.append(
                Series(f"{origin}/{_part(label)}", f"{label} ({objective})", rates, rates[-1])
            )
        series.sort(key=lambda s: -s.final)
        left_out = max(0, len(series) - MAX_SERIES)
        name = f"{robot} {arm} {obj}: running {objective} rate per setting"
        name += f" (best {MAX_SERIES} of {len(series)})" if left_out else ""
        units.append(Unit(origin, name, series[:MAX_SERIES]))
    return units


def log_comparison(rec: Any, units: list[Unit]) -> None:
    """Each series: its name once (static), then its running rate on the episode timeline."""
    import rerun as rr

    for unit in units:
        for series in unit.series:
            rec.log(series.entity, rr.SeriesLines(names=[series.name]), static=True)
            steps = np.arange(1, len(series.rates) + 1, dtype=np.int64)
            rec.send_columns(
                series.entity,
                indexes=[rr.TimeColumn(TIMELINE, sequence=steps)],
                columns=rr.Scalars.columns(scalars=series.rates.astype(float)),
            )


def comparison_views(units: list[Unit]) -> list[Any]:
    """One time-series view per robot, arm and object, legend on, rate axis 0..1."""
    import rerun.blueprint as rrb

    return [
        rrb.TimeSeriesView(
            name=unit.name,
            origin=unit.origin,
            plot_legend=rrb.PlotLegend(visible=True),
            axis_y=rrb.ScalarAxis(range=(0.0, 1.05)),
        )
        for unit in units
    ]
