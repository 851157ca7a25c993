"""Benchmark framework: timed repetitions, robust statistics, JSON for machines, a table for people.

Sections live in ``harness/benchmarks/<section>.py`` and expose ``run(quick: bool) ->
list[Figure]``. Speed is reported as medians with spread over repetitions and, where a
comparison matters, as ratios measured in the same run (this machine is shared and noisy).
Every run records the machine (CPU model, cores, versions) and its load before and after each
section, so a number can be read next to how busy the machine was when it was taken.
"""

from __future__ import annotations

import importlib
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import time
import traceback
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from harness.benchmarks.estimate import (
    Estimate,
    estimate,
    left_line,
    probe_seconds,
    save_times,
)
from harness.benchmarks.machine import (
    cpu_snapshot,
    cpu_use_between,
    load_average,
    usable_cpus,
)
from harness.markdown import markdown_table
from harness.writes import write_file

# Section name -> module under harness.benchmarks, in the order they run.
SECTIONS: tuple[str, ...] = ("grasps", "ik", "timing", "episodes", "graspgen", "sweeps", "sharing")

# What a figure's [low, high] interval is.
PERCENTILES = "p10-p90"  # 10th and 90th percentile of the repetitions
WILSON_95 = "95% Wilson"  # a success rate's 95% Wilson score interval

ROOT = Path(__file__).resolve().parents[2]
VERSIONED_PACKAGES = (
    "pick-harness",
    "mujoco",
    "placo",
    "toppra",
    "ruckig",
    "numpy",
    "scipy",
    "pandas",
    "rerun-sdk",
    "coacd",
)


@dataclass
class Figure:
    """One measured quantity: median and spread over ``repetitions``, plus an optional target.

    ``low`` / ``high`` bound the spread named by ``spread`` (the 10th / 90th percentile of the
    repetitions unless stated otherwise)."""

    section: str
    name: str
    unit: str
    median: float
    low: float
    high: float
    repetitions: int
    target: float | None = None
    higher_is_better: bool = False
    spread: str = PERCENTILES
    notes: str = ""
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def meets_target(self) -> bool | None:
        if self.target is None or not math.isfinite(self.median):
            return None if self.target is None else False
        return self.median >= self.target if self.higher_is_better else self.median <= self.target

    @property
    def target_ratio(self) -> float | None:
        """Median over target (> 1 is over a ceiling, < 1 short of a floor); None without one."""
        if self.target is None or self.target == 0:
            return None
        return self.median / self.target

    def verdict(self) -> str:
        """ "yes", "no (27% over)" / "no (15% short)", or "" without a target."""
        met = self.meets_target
        if met is None:
            return ""
        if met:
            return "yes"
        ratio = self.target_ratio
        if ratio is None or not math.isfinite(ratio):
            return "no"
        if self.higher_is_better:
            return f"no ({1.0 - ratio:.0%} short)"
        return f"no ({ratio - 1.0:.0%} over)"

    def to_json(self) -> dict[str, Any]:
        return asdict(self) | {"meets_target": self.meets_target, "target_ratio": self.target_ratio}


def summarize(samples: list[float]) -> tuple[float, float, float]:
    """Median, 10th and 90th percentile of a non-empty sample list."""
    if not samples:
        raise ValueError("summarize needs at least one sample")
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
    """Build a Figure from raw samples, multiplying each by ``scale`` (e.g. 1e3 for ms).

    Non-finite samples (a step an episode never reached) are left out; ``repetitions`` counts
    the samples used. Without any, the figure is NaN with 0 repetitions."""
    values = [s * scale for s in samples if math.isfinite(s)]
    if not values:
        nan = float("nan")
        return Figure(section, name, unit, nan, nan, nan, 0, **kwargs)
    median, p10, p90 = summarize(values)
    return Figure(section, name, unit, median, p10, p90, len(values), **kwargs)


def rate_figure(section: str, name: str, successes: int, n: int, **kwargs: Any) -> Figure:
    """A success rate in percent over ``n`` trials, its spread the 95% Wilson interval."""
    from harness.report.stats import wilson_interval

    low, high = wilson_interval(successes, n)
    rate = successes / n if n else float("nan")
    return Figure(
        section, name, "%", 100 * rate, 100 * low, 100 * high, n, spread=WILSON_95, **kwargs
    )


# --------------------------------------------------------------------------------------------
# Machine description


def _git_commit() -> str | None:
    """The checked-out commit (``+dirty`` with local changes), or None outside a git tree."""

    def git(*args: str) -> str:
        return subprocess.run(
            ["git", *args], cwd=ROOT, capture_output=True, text=True, timeout=10, check=True
        ).stdout.strip()

    try:
        commit = git("rev-parse", "--short", "HEAD")
        dirty = git("status", "--porcelain", "--untracked-files=no")
    except (OSError, subprocess.SubprocessError):
        return None
    return commit + ("+dirty" if dirty else "")


def _threads_per_core() -> int | None:
    """SMT siblings of CPU 0 (2 = two logical CPUs share one physical core), Linux only."""
    path = Path("/sys/devices/system/cpu/cpu0/topology/thread_siblings_list")
    try:
        text = path.read_text(encoding="ascii").strip()
    except OSError:
        return None
    count = 0
    for part in text.split(","):
        first, _, last = part.partition("-")
        count += int(last) - int(first) + 1 if last else 1
    return count


def machine_info() -> dict[str, Any]:
    """CPU model, core counts, OS, Python and library versions, and the commit measured."""
    info: dict[str, Any] = {
        "cpu_model": platform.processor() or platform.machine(),
        "cpus": os.cpu_count(),
        "usable_cpus": usable_cpus(),
        "threads_per_core": _threads_per_core(),
        "python": platform.python_version(),
        "platform": platform.platform(),
        "commit": _git_commit(),
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

    versions: dict[str, str | None] = {}
    for package in VERSIONED_PACKAGES:
        try:
            versions[package] = version(package)
        except PackageNotFoundError:
            versions[package] = None
    info["versions"] = versions
    return info


def format_machine(info: dict[str, Any], load_start: Any, load_end: Any) -> str:
    """One line for people: CPU, cores, Python, the key libraries, load before / after."""
    versions = info.get("versions", {})
    libraries = ", ".join(
        f"{name} {versions[name]}"
        for name in ("mujoco", "placo", "toppra", "ruckig", "numpy")
        if versions.get(name)
    )
    return (
        f"{info.get('cpu_model')}, {info.get('cpus')} CPUs ({info.get('usable_cpus')} usable), "
        f"Python {info.get('python')}, {libraries}; commit {info.get('commit')}; "
        f"load average (1/5/15 min) {load_start} at start, {load_end} at end"
    )


# --------------------------------------------------------------------------------------------
# Running and reporting


@dataclass
class SectionRun:
    """One section's figures and the machine's state around it."""

    name: str
    figures: list[Figure]
    seconds: float
    load_start: list[float] | None
    load_end: list[float] | None
    others_cpus: float | None  # average CPUs used by other processes while it ran
    error: str | None = None

    def to_json(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "seconds": self.seconds,
            "load_average_start": self.load_start,
            "load_average_end": self.load_end,
            "others_cpus": self.others_cpus,
            "error": self.error,
            "figures": len(self.figures),
        }


def run_section(name: str, quick: bool) -> SectionRun:
    """Run one section; an exception is recorded (and printed) rather than ending the bench."""
    load_start = load_average()
    before = cpu_snapshot()
    figures: list[Figure] = []
    error = None
    try:
        module = importlib.import_module(f"harness.benchmarks.{name}")
        figures = module.run(quick)
    except Exception as exc:  # one broken section must not lose the others' numbers
        traceback.print_exc()
        error = f"{type(exc).__name__}: {exc}"
    use = cpu_use_between(before, cpu_snapshot())
    return SectionRun(name, figures, use.wall_s, load_start, load_average(), use.others_cpus, error)


def run_sections(
    names: list[str] | None, quick: bool, expected: Estimate | None = None
) -> list[SectionRun]:
    """Run the sections in order; with ``expected``, each section's line says how long the
    rest should take (``harness.benchmarks.estimate``)."""
    chosen = names or list(SECTIONS)
    runs: list[SectionRun] = []
    for index, name in enumerate(chosen):
        print(f"bench: {name} ...", file=sys.stderr, flush=True)
        run = run_section(name, quick)
        state = f"failed: {run.error}" if run.error else f"{len(run.figures)} figures"
        runs.append(run)
        done = {r.name: r.seconds for r in runs}
        left = left_line(expected, done, chosen[index + 1 :]) if expected else None
        print(
            f"bench: {name} {state} in {run.seconds:.1f} s" + (f"; {left}" if left else ""),
            file=sys.stderr,
            flush=True,
        )
    return runs


def _number(value: float) -> str:
    return "nan" if not math.isfinite(value) else f"{value:.4g}"


def format_table(figures: list[Figure], escape_html: bool = False) -> str:
    """A plain-text table (also valid Markdown) of the figures; ``escape_html`` for a page
    that renders raw HTML (the terminal gets ``<=`` as typed, not ``&lt;=``).

    The spread column is the 10th - 90th percentile of the repetitions, or the 95% Wilson
    interval for success rates (marked "CI"); one repetition has no spread ("-")."""
    header = ["section", "figure", "median", "spread (p10 – p90)", "reps", "target", "met"]
    rows: list[list[Any]] = []
    for fig in figures:
        target = (
            "" if fig.target is None else f"{'≥' if fig.higher_is_better else '≤'} {fig.target:g}"
        )
        if fig.repetitions <= 1 and fig.spread == PERCENTILES:
            spread = "–"
        else:
            spread = f"{_number(fig.low)} – {_number(fig.high)}"
            if fig.spread == WILSON_95:
                spread += " (CI)"
        verdict = fig.verdict()
        if verdict.startswith("no"):
            verdict = f"**{verdict}**"
        median = f"{_number(fig.median)} {fig.unit}"
        rows.append([fig.section, fig.name, median, spread, fig.repetitions, target, verdict])
    return "\n".join(markdown_table(header, rows, escape_html))


def format_target_notes(figures: list[Figure]) -> str:
    """The notes of every figure that has a target, missed ones first: what was measured and
    under which conditions, which the table has no room for."""
    with_target = [fig for fig in figures if fig.target is not None and fig.notes]
    with_target.sort(key=lambda fig: fig.meets_target is not False)
    lines, previous = [], None
    for fig in with_target:
        note = fig.notes if fig.notes != previous else "(as above)"
        lines.append(f"- {fig.section} / {fig.name}: {fig.verdict()}; {note}")
        previous = fig.notes
    return "\n".join(lines)


def bench_payload(
    runs: list[SectionRun],
    quick: bool,
    info: dict[str, Any],
    load_start: list[float] | None,
    load_end: list[float] | None,
    seconds: float,
) -> dict[str, Any]:
    """The JSON document: machine, load, per-section state and every figure."""
    return {
        "machine": info | {"load_average_start": load_start, "load_average_end": load_end},
        "quick": quick,
        "time": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "seconds": seconds,
        "sections": [run.to_json() for run in runs],
        "figures": [fig.to_json() for run in runs for fig in run.figures],
    }


def json_safe(value: Any) -> Any:
    """``value`` with NaN / infinities as None, so the file is strict JSON (RFC 8259)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {str(key): json_safe(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(item) for item in value]
    return value


def main_bench(names: list[str] | None, quick: bool, json_path: str | None) -> list[SectionRun]:
    """Run the sections, print the machine line and the table, and write the JSON if asked."""
    info = machine_info()
    load_start = load_average()
    probe_s = probe_seconds()
    expected = estimate(quick, probe_s)
    print(expected.line(names or list(SECTIONS)), file=sys.stderr, flush=True)
    start = time.perf_counter()
    runs = run_sections(names, quick, expected)
    seconds = time.perf_counter() - start
    save_times(quick, probe_s, {run.name: run.seconds for run in runs if run.error is None})
    load_end = load_average()
    print(format_machine(info, load_start, load_end))
    print()
    figures = [fig for run in runs for fig in run.figures]
    print(format_table(figures))
    notes = format_target_notes(figures)
    if notes:
        print(f"\n{notes}")
    print(f"\n{'quick' if quick else 'full'} run, {seconds:.0f} s")
    for run in runs:
        if run.error:
            print(f"section {run.name} failed: {run.error}")
    if json_path:
        path = Path(json_path)
        payload = bench_payload(runs, quick, info, load_start, load_end, seconds)
        text = json.dumps(json_safe(payload), indent=2, default=str, allow_nan=False)
        write_file(path, text + "\n")
        print(f"wrote {path}")
    return runs
