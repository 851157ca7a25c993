"""The one sensitivity table of ``harness sensitivity``: per chosen value and arm, the valid rate
of the canonical setting at 0.5x / 1x / 2x, the best setting at each, and the answer.

Answers (on the valid verdict, 95% Wilson intervals):

- ``best setting flips``: the approach cone with the highest valid lower bound (ties keep the
  canonical one) is not the same at every value: a recommendation depends on the chosen value;
- ``moves``: the canonical setting's valid interval at an off-default value does not overlap
  its interval at the default: the rate reported at the default is a statement about it;
- ``stable`` otherwise.

Pure pandas over the runs' rows (``episodes.csv`` of each value's sweep and of its baseline,
the baseline on the value's seeds: the three columns are paired, same seeds).
"""

from __future__ import annotations

import json
from typing import Any, cast

import pandas as pd

from harness.report.frames import column, frame_of
from harness.report.sections import Table
from harness.report.sensitivity import FLIP, MOVES, STABLE
from harness.report.stats import wilson_interval

CANONICAL = ["downward", 140]
CONE = "param.pick.approach_filter"


def _parsed(value: Any) -> Any:
    if isinstance(value, str):
        try:
            return json.loads(value)
        except json.JSONDecodeError:
            return value
    return value


def _same(a: Any, b: Any) -> bool:
    a, b = _parsed(a), _parsed(b)
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return abs(float(a) - float(b)) <= 1e-9 * max(1.0, abs(float(b)))
    return a == b


def _cone(value: Any) -> list[Any]:
    parsed = _parsed(value)
    return [parsed[0], float(parsed[1])] if isinstance(parsed, list) else [parsed]


def _cone_text(cone: list[Any]) -> str:
    return " ".join(f"{c:g}" if isinstance(c, float) else str(c) for c in cone)


def _counts(rows: pd.DataFrame) -> tuple[int, int]:
    """(valid, judged) over rated rows (errors and not_runnable rows left out)."""
    rated = frame_of(rows[column(rows, "failure_reason").fillna("") != "error"])
    if "not_runnable" in rated:
        rated = frame_of(rated[~column(rated, "not_runnable").fillna(False).astype(bool)])
    return int(column(rated, "valid").fillna(False).astype(bool).sum()), len(rated)


def value_rows(
    label: str,
    key: str,
    default: Any,
    values: tuple[Any, ...],
    swept: pd.DataFrame,
    baseline: pd.DataFrame,
) -> list[list[str]]:
    """The table rows of one chosen value: one per (robot, arm, object)."""
    column = f"param.{key}"
    levels = [values[0], default, values[1]]
    # Paired: the baseline on the seeds the value ran (a baseline may have run more of them).
    if "seed" in baseline and "seed" in swept:
        baseline = frame_of(baseline[baseline["seed"].isin(list(set(swept["seed"])))])
    frames = []
    for index, level in enumerate(levels):
        if index == 1:
            part = baseline.copy()
        else:
            mask = swept[column].map(lambda v, level=level: _same(v, level))
            part = swept[mask].copy()
        part["_level"] = index
        frames.append(part)
    rows = pd.concat(frames, ignore_index=True)
    out: list[list[str]] = []
    for key_, unit in rows.groupby(["robot", "arm", "object"], sort=True):
        robot, arm, obj = cast(tuple[Any, Any, Any], key_)
        cells, bests, spans = [], [], []
        for index in range(3):
            at = unit[unit["_level"] == index]
            by_cone: dict[str, tuple[int, int]] = {}
            for cone_value, cone_rows in at.groupby(CONE, sort=True):
                by_cone[_cone_text(_cone(cone_value))] = _counts(frame_of(cone_rows))
            canonical = _cone_text([CANONICAL[0], float(CANONICAL[1])])
            valid, judged = by_cone.get(canonical, (0, 0))
            cells.append(f"{valid}/{judged}" if judged else "–")
            spans.append(wilson_interval(valid, judged) if judged else None)
            ranked = sorted(
                by_cone.items(),
                key=lambda item: (wilson_interval(*item[1])[0] if item[1][1] else -1.0,
                                  item[0] == canonical),
                reverse=True,
            )  # fmt: skip
            bests.append(ranked[0][0] if ranked else "–")
        flips = len(set(bests)) > 1
        moved = any(
            span is not None
            and spans[1] is not None
            and (span[1] < spans[1][0] or spans[1][1] < span[0])
            for span in (spans[0], spans[2])
        )
        answer = FLIP if flips else MOVES if moved else STABLE
        best = bests[1] if not flips else " / ".join(bests)
        out.append([label, f"{robot} {arm} {obj}", *cells, best, answer])
    return out


HEADER = ["value (sweep key)", "arm, object", "0.5x", "1x", "2x", "best cone", "answer"]


def sensitivity_table(rows: list[list[str]], episodes: int) -> Table:
    """The table over every value's rows."""
    return Table(
        "Sensitivity of every chosen value",
        HEADER,
        rows,
        note=(
            f"Valid successes / episodes of the canonical approach (downward 140), {episodes} "
            "seeds per point, at the value's low end, its default (the baseline sweep, same "
            "seeds) and its high end (0.5x and 2x unless the value's label gives its range). "
            "Best cone: the approach cone (downward 140 or 120) with the higher valid Wilson "
            f"lower bound, per value. '{FLIP}': the best cone differs across the values; "
            f"'{MOVES}': the canonical rate's 95% interval at an end does not overlap the "
            f"default's; '{STABLE}' otherwise."
        ),
    )
