"""Comparing two runs: per-setting success-rate differences, paired when the runs share seeds.

``compare_runs(run_a, run_b)`` matches the points of two runs by their *settings*, not by point
ids: the filters each episode ran with, per EE axis of its robot (``approach_filter`` /
``facing_filter`` resolved onto the robot's axes, so a sweep over ``pick.approach_filter`` matches
a task file's ``filter_z_dir`` on fr3), ``direction_to_obj`` and the other swept keys. When both
runs hold episodes with the same seeds for a matched setting (two sweeps with the same sweep seed
see the same scenes), the difference is tested with the exact McNemar test on those pairs;
otherwise with the two-proportion test (``compare_proportions``: z, or Fisher's exact test for
small expected counts).

``match="arm"`` pairs the runs by robot, arm and object instead, whatever filters each side ran:
a tuned task file against the current one (``filters_a`` / ``filters_b`` say which filters each
side ran). ``"auto"`` (the default) matches by arm when each run holds one setting per robot, arm
and object (two plain ``harness run`` s), else by settings.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, cast

import pandas as pd

from harness.errors import HarnessError
from harness.report.frames import column, frame_of, series_rows
from harness.report.stats import compare_proportions, mcnemar_exact
from harness.report.tables import judged_mask, load_episodes
from harness.robots.facts import reference_convention
from harness.row import KEY_COLUMNS, param_columns

AXIS_KEYS = ("filter_x_dir", "filter_y_dir", "filter_z_dir")
NEUTRAL_KEYS = ("approach_filter", "facing_filter")
SELECTION_KEYS = (*AXIS_KEYS, *NEUTRAL_KEYS, "direction_to_obj")
# Swept keys the key columns already show (the object's name follows its mesh).
SHOWN_BY_KEY = ("param.object.mesh", "param.objects.0.mesh")
MATCH_KEY = [*KEY_COLUMNS, "settings"]
ARM_KEY = ["robot", "arm", "object"]
MATCHES = ("auto", "settings", "arm")


def _filter(text: Any) -> list[Any] | None:
    """A filter cell (JSON text, '' or NaN) as ``[direction, float, ...]`` or None."""
    if not isinstance(text, str) or not text or text == "null":
        return None
    direction, *angles = json.loads(text)
    return [direction, *(float(a) for a in angles)]


def _axes(robot: str) -> dict[str, str] | None:
    """``approach_filter`` / ``facing_filter`` -> the robot's ``filter_*_dir`` (None: unknown)."""
    try:
        convention = reference_convention(robot)
    except (HarnessError, FileNotFoundError):
        return None
    return {
        "approach_filter": f"filter_{convention.approach_axis}_dir",
        "facing_filter": f"filter_{convention.facing_axis}_dir",
    }


def _settings(row: dict[str, Any], others: list[str]) -> str:
    """One episode's settings as sorted JSON (filters on the robot's own axes)."""
    cells = {key: row.get(f"param.pick.{key}", row.get(key, "")) for key in SELECTION_KEYS}
    settings: dict[str, Any] = {key: _filter(cells[key]) for key in AXIS_KEYS}
    axes = _axes(str(row["robot"]))
    for key in NEUTRAL_KEYS:
        value = _filter(cells[key])
        if axes is None:
            settings[key] = value
        elif value is not None or f"param.pick.{key}" in row:
            settings[axes[key]] = value
    side = cells["direction_to_obj"]
    settings["direction_to_obj"] = side if isinstance(side, str) and side else None
    settings.update({name.removeprefix("param."): row[name] for name in others})
    return json.dumps({k: v for k, v in settings.items() if v is not None}, sort_keys=True)


def with_settings(frame: pd.DataFrame) -> pd.DataFrame:
    """``frame`` with a ``settings`` column (see :func:`_settings`)."""
    params = param_columns(frame.columns)
    selection = {f"param.pick.{key}" for key in SELECTION_KEYS}
    others = [p for p in params if p not in selection and p not in SHOWN_BY_KEY]
    present = [c for c in (*SELECTION_KEYS, *params, "robot") if c in frame.columns]
    cache: dict[tuple[Any, ...], str] = {}
    values = []
    for cells in frame[present].itertuples(index=False, name=None):
        if cells not in cache:
            row = {k: v for k, v in zip(present, cells, strict=True) if not _missing(v)}
            cache[cells] = _settings(row, [o for o in others if o in row])
        values.append(cache[cells])
    return frame.assign(settings=values)


def _missing(value: Any) -> bool:
    return isinstance(value, float) and math.isnan(value)


def filters_text(settings: str) -> str:
    """A settings JSON as ``filter_z_dir downward 140, filter_x_dir forward 90`` ("none")."""
    parsed = json.loads(settings) if settings else {}
    parts = [
        f"{key} {value[0]} {'-'.join(f'{a:g}' for a in value[1:])}"
        if isinstance(value, list) else f"{key} {value}"
        for key, value in sorted(parsed.items())
    ]  # fmt: skip
    return ", ".join(parts) or "none"


def one_setting_per_arm(frame: pd.DataFrame) -> bool:
    """True when every robot, arm and object of ``frame`` ran one setting (a plain run)."""
    return bool((frame.groupby(ARM_KEY)["settings"].nunique() == 1).all())


def _by_arm(frame: pd.DataFrame) -> pd.DataFrame:
    """``frame`` keyed by robot, arm and object only: task and settings become one value."""
    filters = frame.groupby(ARM_KEY)["settings"].transform(
        lambda s: " | ".join(filters_text(x) for x in dict.fromkeys(s))
    )
    return frame.assign(filters=filters, settings="", task="")


def _side(frame: pd.DataFrame, verdict: str = "success") -> pd.DataFrame:
    """Per matched setting: point, point_id, n, successes and the seed -> success record
    (``verdict``: the ``success`` or the ``valid`` column)."""
    rows = []
    if "filters" not in frame:
        frame = frame.assign(filters=[filters_text(s) for s in frame["settings"]])
    for key, group in frame.groupby(MATCH_KEY, sort=False):
        seeds = column(group, "seed") if "seed" in group else pd.Series([-1] * len(group))
        record = dict(zip(seeds, column(group, verdict).astype(bool), strict=True))
        paired = bool((seeds >= 0).all()) and seeds.is_unique
        rows.append(
            {
                **dict(zip(MATCH_KEY, cast(tuple[Any, ...], key), strict=True)),
                "point_id": int(column(group, "point_id").min()),
                "point": str(group["point"].iloc[0]),
                "n": len(group),
                "successes": int(column(group, verdict).astype(bool).sum()),
                "filters": str(group["filters"].iloc[0]),
                "record": record if paired else None,
            }
        )
    return pd.DataFrame(rows)


def _test(row: Any) -> dict[str, Any]:
    """The test of one matched setting: McNemar on shared seeds, else two proportions."""
    record_a, record_b = row["record_a"], row["record_b"]
    shared = sorted(set(record_a) & set(record_b)) if record_a and record_b else []
    if shared:
        only_a = sum(record_a[s] and not record_b[s] for s in shared)
        only_b = sum(record_b[s] and not record_a[s] for s in shared)
        result = mcnemar_exact(only_a, only_b)
        difference = row["successes_b"] / row["n_b"] - row["successes_a"] / row["n_a"]
        return dict(difference=difference, z=math.nan, p_value=result.p_value,
                    test="mcnemar", pairs=len(shared), only_a=only_a, only_b=only_b)  # fmt: skip
    result = compare_proportions(
        int(row["successes_a"]), int(row["n_a"]), int(row["successes_b"]), int(row["n_b"])
    )
    return dict(difference=result.difference, z=result.z, p_value=result.p_value,
                test=result.test, pairs=0, only_a=0, only_b=0)  # fmt: skip


def compare_runs(
    run_a: str | Path, run_b: str | Path, match: str = "settings", objective: str = "valid"
) -> pd.DataFrame:
    """Per matched setting, ``rate_b - rate_a`` with its test (see the module docstring).

    ``objective`` ``valid`` (the default) compares the validity verdicts; ``reference`` the
    reference success (also used, and said in ``verdict``, when neither run judged validity).
    Settings found in one run only are listed with ``present`` = ``a only`` / ``b only`` and no
    test. ``test`` is ``mcnemar`` (paired: ``pairs`` shared seeds, ``only_a`` / ``only_b``
    discordant successes), ``z`` or ``fisher``.
    """
    if match not in MATCHES:
        raise HarnessError(f"match {match!r}: expected one of {', '.join(MATCHES)}")
    frame_a = with_settings(load_episodes(run_a))
    frame_b = with_settings(load_episodes(run_b))
    if match == "auto":
        both = one_setting_per_arm(frame_a) and one_setting_per_arm(frame_b)
        match = "arm" if both else "settings"
    if match == "arm":
        frame_a, frame_b = _by_arm(frame_a), _by_arm(frame_b)
    judged = bool(judged_mask(frame_a).any() or judged_mask(frame_b).any())
    verdict = "valid" if objective == "valid" and judged else "success"
    merged = pd.merge(_side(frame_a, verdict), _side(frame_b, verdict), on=MATCH_KEY, how="outer",
                      suffixes=("_a", "_b"), indicator=True)  # fmt: skip
    merged["present"] = (
        merged.pop("_merge")
        .map({"both": "both", "left_only": "a only", "right_only": "b only"})
        .astype("str")
    )
    tests = []
    for row in series_rows(merged):
        if row["present"] == "both":
            tests.append(_test(row))
        else:
            tests.append(dict(difference=math.nan, z=math.nan, p_value=math.nan, test="",
                              pairs=0, only_a=0, only_b=0))  # fmt: skip
    merged = pd.concat([merged.reset_index(drop=True), pd.DataFrame(tests)], axis=1)
    merged["point_id"] = merged["point_id_a"].fillna(merged["point_id_b"]).astype("int64")
    merged["point"] = merged["point_a"].fillna(merged["point_b"])
    for name in ("n_a", "successes_a", "n_b", "successes_b"):
        merged[name] = merged[name].fillna(0).astype("int64")
    merged["rate_a"] = merged["successes_a"] / merged["n_a"].where(merged["n_a"] > 0)
    merged["rate_b"] = merged["successes_b"] / merged["n_b"].where(merged["n_b"] > 0)
    params = _settings_columns(merged)
    merged["match"] = match
    merged["verdict"] = "valid" if verdict == "valid" else "reference"
    for name in ("filters_a", "filters_b"):
        merged[name] = merged[name].fillna("")
    columns = [*KEY_COLUMNS, "match", "point_id", "point", "settings", "filters_a", "filters_b",
               *params.columns, "n_a",
               "successes_a", "rate_a", "n_b", "successes_b", "rate_b", "difference", "z",
               "p_value", "test", "pairs", "only_a", "only_b", "present", "verdict"]  # fmt: skip
    merged = pd.concat([merged, params], axis=1)
    merged = merged.sort_values(["robot", "arm", "object", "task", "point_id"], kind="stable")
    return frame_of(merged[columns]).reset_index(drop=True)


def _settings_columns(merged: pd.DataFrame) -> pd.DataFrame:
    """``param.<key>`` columns from the settings JSON (filters as JSON text), for display."""
    parsed = [json.loads(s) if s else {} for s in merged["settings"]]
    keys = sorted({k for item in parsed for k in item})
    data = {
        f"param.{k}": [
            json.dumps(item[k]) if isinstance(item.get(k), list) else item.get(k, "")
            for item in parsed
        ]
        for k in keys
    }
    return pd.DataFrame(data, index=merged.index)
