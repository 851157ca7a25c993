"""The run's objective: which verdict ranks settings, colours the heatmaps and answers "which
setting" (``valid``: the grasp really holds, the default; ``reference``: InternDataEngine's
``is_success``). One objective per run: the report records the one it used in ``report.json``,
so ``harness report RUN_DIR`` without ``--objective`` uses it again; the other rate is always
shown beside it.

A run without any episode the validity phase judged (validity off, or a reference-objective
tune, which skips the phase) has no valid rate: ``effective_objective`` then falls back to the
reference rate and says so.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from harness.errors import HarnessError
from harness.files import write_atomic
from harness.report.frames import column

VALID, REFERENCE = "valid", "reference"
OBJECTIVES: tuple[str, ...] = (VALID, REFERENCE)
DEFAULT_OBJECTIVE = VALID
RECORD_NAME = "report.json"  # the objective the run's report used


@dataclass(frozen=True)
class Rate:
    """One verdict's columns in a summary row: count, denominator, rate and Wilson bounds."""

    name: str  # "valid" or "reference"
    k: str
    n: str
    rate: str
    lo: str
    hi: str

    def of(self, row: Any) -> tuple[int, int, float, float, float]:
        """(k, n, rate, lo, hi) of one summary row; n = 0 gives NaN rate and bounds."""
        n = int(row.get(self.n, 0) or 0)
        k = int(row.get(self.k, 0) or 0)
        nan = math.nan
        if not n:
            return k, 0, nan, nan, nan
        return k, n, float(row[self.rate]), float(row[self.lo]), float(row[self.hi])

    def text(self, row: Any, interval: bool = True) -> str:
        """``valid 31/40 (78%, 0.62–0.88)``; ``valid: not judged`` when n = 0."""
        k, n, rate, lo, hi = self.of(row)
        if not n:
            return f"{self.name}: not judged" if self.name == VALID else f"{self.name}: none rated"
        ci = f", {lo:.2f}–{hi:.2f}" if interval and not math.isnan(lo) else ""
        return f"{self.name} {k}/{n} ({rate:.0%}{ci})"


RATES = {
    VALID: Rate(VALID, "valid", "n_judged", "valid_rate", "valid_ci_low", "valid_ci_high"),
    REFERENCE: Rate(REFERENCE, "successes", "n", "rate", "wilson_lo", "wilson_hi"),
}


def check(objective: str) -> str:
    if objective not in OBJECTIVES:
        raise HarnessError(f"objective {objective!r}: expected one of {', '.join(OBJECTIVES)}")
    return objective


def other(objective: str) -> str:
    """The verdict shown beside the objective."""
    return REFERENCE if objective == VALID else VALID


def judged(summary: pd.DataFrame) -> bool:
    """Whether any episode of the summary was judged by the validity phase."""
    return "n_judged" in summary and bool(column(summary, "n_judged").fillna(0).sum() > 0)


def effective_objective(summary: pd.DataFrame, objective: str) -> str:
    """``objective``, or ``reference`` when it is ``valid`` and no episode was judged."""
    check(objective)
    return REFERENCE if objective == VALID and not judged(summary) else objective


def recorded_objective(run_dir: Path) -> str | None:
    """The objective the run's last report used (``report.json``), if any."""
    path = Path(run_dir) / RECORD_NAME
    if not path.is_file():
        return None
    try:
        value = json.loads(path.read_text(encoding="utf-8")).get("objective")
    except (json.JSONDecodeError, AttributeError, OSError):
        return None
    return value if value in OBJECTIVES else None


def resolve_objective(run_dir: Path, objective: str | None) -> str:
    """The flag's objective, else the run's recorded one, else the default (``valid``)."""
    if objective is not None:
        return check(objective)
    return recorded_objective(run_dir) or DEFAULT_OBJECTIVE


def record_objective(run_dir: Path, objective: str, effective: str) -> Path:
    """Write ``report.json``: the objective asked for and the one the rates could use."""
    path = Path(run_dir) / RECORD_NAME
    text = json.dumps({"objective": objective, "effective_objective": effective}, indent=2)
    write_atomic(path, text + "\n", root=Path(run_dir))
    return path
