"""What a sweep report may call "best" for a unit: ``recommendation(units_df)``.

A sweep's per-point table ranks settings by a rate; when every setting of a unit is at 0% (or
its best is indistinguishable from nothing), naming one "best" is wrong: no setting helps, and
the report should say so with the dominant failure cause. This is the rule the tune's
"no setting helps" decision uses (``harness.tuning.decide.FLOOR``): the best setting's exact
95% upper bound below 10%, or no success at all. For ``harness.report`` (report.html's best
table) to call on its ``best_settings`` rows.
"""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

from harness.tuning.decide import FLOOR
from harness.tuning.intervals import exact_interval


@dataclass(frozen=True)
class Recommendation:
    """Per unit: the setting to name as best, or None with the reason no setting helps."""

    best_index: object | None  # the row label of the recommended setting; None: none helps
    verdict: str  # "best" or "no setting helps"
    reason: str


def recommendation(
    units_df: pd.DataFrame, successes: str = "successes", n: str = "n", cause: str = ""
) -> Recommendation:
    """``units_df``: one unit's settings (one row each, ``successes`` of ``n``). The row with
    the most successes (ties: the first) is "best" unless no row succeeded or its exact 95%
    upper bound is below ``FLOOR``; then "no setting helps" with ``cause`` (e.g.
    ``harness.tuning.causes.cause_sentence`` of the unit's rows)."""
    if units_df.empty:
        return Recommendation(None, "no setting helps", "no settings")
    counts = units_df[successes].astype(int)
    best = counts.idxmax()
    k, total = int(counts.loc[best]), int(units_df.loc[best, n])
    hi = float(exact_interval(k, total)[1]) if total else 1.0
    if k == 0 or hi < FLOOR:
        why = f"best {k}/{total} (95% upper bound {hi:.2f} < {FLOOR:.0%})" if k else "0% everywhere"
        return Recommendation(None, "no setting helps", why + (f"; {cause}" if cause else ""))
    return Recommendation(best, "best", f"{k}/{total}")
