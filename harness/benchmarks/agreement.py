"""Agreement of two runs of the same sweep on the two engines, per sweep point.

``python -m harness.benchmarks.agreement CPU_RUN GPU_RUN`` reads both runs' ``episodes.csv``
(``harness sweep X`` and ``harness sweep X --engine mjwarp``), matches rows on (task, point,
episode), and prints per point (a task's setting: the demo's points repeat over its five arms)
the reference success rate and the valid rate of each engine with Wilson 95% intervals, whether
each engine's rate lies inside the other's interval, and the per-episode agreement (reference
outcome: success and failure reason; validity) over the episodes executed on both; then each
task's pooled line and the whole run's. Pooled agreement can hide a gap at one setting (issue
34: at ``downward 160`` 12 points of valid rate), hence the per-point table.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

import pandas as pd

Z95 = 1.959963984540054  # the two-sided 95% normal quantile


def wilson(successes: int, n: int) -> tuple[float, float]:
    """Wilson score 95% interval of a proportion (0, 1 when n is 0)."""
    if n == 0:
        return 0.0, 1.0
    p = successes / n
    centre = (p + Z95**2 / (2 * n)) / (1 + Z95**2 / n)
    half = Z95 * math.sqrt(p * (1 - p) / n + Z95**2 / (4 * n * n)) / (1 + Z95**2 / n)
    return max(0.0, centre - half), min(1.0, centre + half)


def _executed(steps: Any) -> Any:
    """Rows whose pick ran on the engine (a plan that failed has no physics steps)."""
    numbers: Any = pd.to_numeric(steps, errors="coerce")
    return numbers.fillna(0) > 0


def _reason(reasons: Any) -> Any:
    return reasons.fillna("").astype(str)


def matched(cpu: pd.DataFrame, gpu: pd.DataFrame) -> Any:
    """The two runs' rows side by side (suffixes ``_cpu``, ``_gpu``), matched on the task, the
    point and the episode."""
    keys = ["task", "point", "episode_id"]
    return cpu.merge(gpu, on=keys, suffixes=("_cpu", "_gpu"), validate="one_to_one")


def per_point(cpu: pd.DataFrame, gpu: pd.DataFrame) -> pd.DataFrame:
    """One record per (task, point), one per task (``TASK all``) when the run has several,
    and one ``all`` record: rates, intervals and agreement."""
    both: Any = matched(cpu, gpu)
    records = []
    groups = []
    tasks = list(both.groupby("task", sort=True))
    for task, task_rows in tasks:
        groups += [(f"{task} {point}", rows) for point, rows in task_rows.groupby("point")]
        if len(tasks) > 1:
            groups.append((f"{task} all", task_rows))
    for point, rows in [*groups, ("all", both)]:
        record: dict[str, object] = {"point": point, "n": len(rows)}
        inside = {}
        for measure in ("success", "valid"):
            rates = {}
            for engine in ("cpu", "gpu"):
                hits = int(rows[f"{measure}_{engine}"].astype(bool).sum())
                low, high = wilson(hits, len(rows))
                rates[engine] = (hits / max(1, len(rows)), low, high)
                record[f"{measure}_{engine}"] = rates[engine][0]
                record[f"{measure}_{engine}_ci"] = f"{low:.3f}-{high:.3f}"
            (a, a_low, a_high), (b, b_low, b_high) = rates["cpu"], rates["gpu"]
            inside[measure] = a_low <= b <= a_high and b_low <= a <= b_high
            record[f"{measure}_inside"] = inside[measure]
        executed = rows[_executed(rows["sim_steps_cpu"]) & _executed(rows["sim_steps_gpu"])]
        same_ref = (
            executed["success_cpu"].astype(bool) == executed["success_gpu"].astype(bool)
        ) & (_reason(executed["failure_reason_cpu"]) == _reason(executed["failure_reason_gpu"]))
        same_valid = executed["valid_cpu"].astype(bool) == executed["valid_gpu"].astype(bool)
        record["executed"] = len(executed)
        record["reference_agree"] = float(same_ref.mean()) if len(executed) else math.nan
        record["valid_agree"] = float(same_valid.mean()) if len(executed) else math.nan
        records.append(record)
    return pd.DataFrame.from_records(records)


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 2:
        print("usage: python -m harness.benchmarks.agreement CPU_RUN GPU_RUN", file=sys.stderr)
        return 2
    cpu, gpu = (pd.read_csv(Path(run) / "episodes.csv") for run in args)
    table = per_point(cpu, gpu)
    columns = [
        "point", "n", "success_cpu", "success_gpu", "success_inside", "valid_cpu", "valid_gpu",
        "valid_cpu_ci", "valid_gpu_ci", "valid_inside", "executed", "reference_agree",
        "valid_agree",
    ]  # fmt: skip
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(table[columns].round(4).to_string(index=False))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
