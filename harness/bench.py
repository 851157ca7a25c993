"""Benchmark framework: timed repetitions, robust statistics, JSON for machines, a table for people.

Sections live in ``harness/benchmarks/<section>.py`` and expose ``run(quick: bool) ->
list[Figure]``. Speed is reported as medians with spread over repetitions and, where a
comparison matters, as ratios measured in the same run (this machine is shared and noisy).
"""

from __future__ import annotations

import importlib
import json
import platform
import statistics
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

# Section name -> module under harness.benchmarks, in the order they run.
SECTIONS: tuple[str, ...] = ("grasps", "ik", "timing", "episodes", "graspgen", "sweeps")


@dataclass
class Figure:
    """One measured quantity: median and spread over ``repetitions``, plus an optional target."""

    section: str
    name: str
    unit: str
    median: float
    p10: float
    p90: float
    repetitions: int
    target: float | None = None
    higher_is_better: bool = False
    notes: str = ""
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def meets_target(self) -> bool | None:
        if self.target is None:
            return None
        return self.median >= self.target if self.higher_is_better else self.median <= self.target


def summarize(samples: list[float]) -> tuple[float, float, float]:
    """Median, 10th and 90th percentile of a non-empty sample list."""
    ordered = sorted(samples)
    if len(ordered) == 1:
        return ordered[0], ordered[0], ordered[0]
    deciles = statistics.quantiles(ordered, n=10, method="inclusive")
    return statistics.median(ordered), deciles[0], deciles[-1]


def time_call(fn: Callable[[], Any], repetitions: int, warmup: int = 1) -> list[float]:
    """Wall-clock seconds of ``fn()`` per repetition, after ``warmup`` untimed calls."""
    for _ in range(warmup):
        fn()
    samples = []
    for _ in range(repetitions):
        start = time.perf_counter()
        fn()
        samples.append(time.perf_counter() - start)
    return samples


def figure(
    section: str,
    name: str,
    samples: list[float],
    unit: str,
    scale: float = 1.0,
    **kwargs: Any,
) -> Figure:
    """Build a Figure from raw samples, multiplying each by ``scale`` (e.g. 1e3 for ms)."""
    median, p10, p90 = summarize([s * scale for s in samples])
    return Figure(section, name, unit, median, p10, p90, len(samples), **kwargs)


def machine_info() -> dict[str, Any]:
    import os

    info: dict[str, Any] = {
        "python": platform.python_version(),
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpus": os.cpu_count(),
    }
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as handle:
            for line in handle:
                if line.startswith("model name"):
                    info["cpu_model"] = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    from importlib.metadata import PackageNotFoundError, version

    for package in ("mujoco", "placo", "toppra", "ruckig", "rerun-sdk", "numpy", "pandas"):
        try:
            info[package] = version(package)
        except PackageNotFoundError:
            info[package] = None
    return info


def run_sections(names: list[str] | None, quick: bool) -> list[Figure]:
    figures: list[Figure] = []
    for name in names or list(SECTIONS):
        module = importlib.import_module(f"harness.benchmarks.{name}")
        figures.extend(module.run(quick))
    return figures


def format_table(figures: list[Figure]) -> str:
    """A plain-text table (also valid Markdown) of the figures."""
    rows = [
        "| section | figure | median | p10 – p90 | reps | target | met |",
        "|---|---|---|---|---|---|---|",
    ]
    for fig in figures:
        target = (
            "" if fig.target is None else f"{'≥' if fig.higher_is_better else '≤'} {fig.target:g}"
        )
        met = {None: "", True: "yes", False: "**no**"}[fig.meets_target]
        rows.append(
            f"| {fig.section} | {fig.name} | {fig.median:.4g} {fig.unit} | "
            f"{fig.p10:.4g} – {fig.p90:.4g} | {fig.repetitions} | {target} | {met} |"
        )
    return "\n".join(rows)


def main_bench(names: list[str] | None, quick: bool, json_path: str | None) -> list[Figure]:
    figures = run_sections(names, quick)
    print(format_table(figures))
    if json_path:
        path = Path(json_path)
        path.parent.mkdir(parents=True, exist_ok=True)
        payload = {
            "machine": machine_info(),
            "quick": quick,
            "time": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "figures": [asdict(fig) | {"meets_target": fig.meets_target} for fig in figures],
        }
        path.write_text(json.dumps(payload, indent=2), encoding="utf-8")
        print(f"wrote {path}")
    return figures
