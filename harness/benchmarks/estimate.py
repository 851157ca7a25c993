"""How long a ``harness bench`` run will take, from measurements rather than a promise.

The help once said ``--quick`` takes ~25 s; on a shared 2-vCPU box it took 213 s (issue 36).
Now the bench times a short CPU probe (``probe_seconds``: ~0.1-0.3 s of numpy and Python, one
core) before it starts, and scales measured section times by how fast this machine runs the
probe now: the times of this machine's previous run (``TIMES_NAME`` in the cache folder, with
that run's probe), else ``REFERENCE`` (a run of this code on the project's 2-vCPU box, with its
probe). A loaded machine runs the probe slower and gets a longer estimate. After each section
the bench says how long the rest should take, from the same figures.
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

TIMES_NAME = "bench-times.json"
PROBE_ROUNDS = 3  # the probe's median of three: one busy moment does not set the estimate

# `harness bench --quick` on the project's development box (Intel Xeon KVM guest, 2 vCPUs,
# shared: load average 11.1 at the start, 11.0 at the end, i.e. ~5 runnable processes per
# core), 2026-11-27, commit 88c7a69 (the sections as at main's 282c9e5) with this module:
# 388 s in all, seconds per section and the probe of the same run. No full run has been
# measured with a probe yet: the first full run on a machine estimates nothing; later ones use
# its times. The same command's run before it, without the probe: 348 s (load 7.4 to 11.6).
REFERENCE: dict[str, dict[str, Any]] = {
    "quick": {
        "commit": "88c7a69",
        "probe_s": 0.0829,
        "sections": {
            "grasps": 9.9,
            "ik": 4.7,
            "timing": 2.6,
            "episodes": 31.2,
            "graspgen": 21.4,
            "sweeps": 122.7,
            "sharing": 195.4,
        },
    },
}


@dataclass(frozen=True)
class Estimate:
    """Seconds per section for this run, and where the figures come from."""

    sections: dict[str, float]  # name -> expected seconds (sections without a figure absent)
    source: str

    def total(self, names: list[str]) -> float | None:
        """Seconds for ``names``; None when a section has no figure."""
        if any(name not in self.sections for name in names):
            return None
        return sum(self.sections[name] for name in names)

    def line(self, names: list[str]) -> str:
        total = self.total(names)
        missing = [name for name in names if name not in self.sections]
        if total is None:
            known = [name for name in names if name in self.sections]
            rest = (
                f"; the other sections about {_minutes(self.total(known) or 0.0)} ({self.source})"
                if known
                else f" ({self.source})"
            )
            return f"bench: no measured time for {', '.join(missing)} yet{rest}"
        return f"bench: about {_minutes(total)} expected ({self.source})"


def _minutes(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 120 else f"{seconds / 60:.1f} min"


def probe_seconds(rounds: int = PROBE_ROUNDS) -> float:
    """Median wall time of a fixed CPU-bound job (small matrix products and a Python loop,
    ~0.03-0.1 s each on one core): how fast this machine runs work now."""
    rng = np.random.default_rng(0)
    matrix = rng.standard_normal((64, 64))
    samples = []
    for _ in range(rounds):
        start = time.perf_counter()
        product = matrix
        for _ in range(200):
            product = np.tanh(product @ matrix * 0.01)
        total = 0
        for k in range(200_000):
            total += k % 7
        samples.append(time.perf_counter() - start)
    return sorted(samples)[len(samples) // 2]


def cache_file() -> Path:
    """``$PICK_HARNESS_CACHE/bench-times.json``, else under ``$XDG_CACHE_HOME`` or
    ``~/.cache``, ``pick-harness/``."""
    root = os.environ.get("PICK_HARNESS_CACHE")
    if root:
        return Path(root).expanduser() / TIMES_NAME
    xdg = os.environ.get("XDG_CACHE_HOME")
    base = Path(xdg).expanduser() if xdg else Path.home() / ".cache"
    return base / "pick-harness" / TIMES_NAME


def _stored(path: Path, mode: str) -> dict[str, Any] | None:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    entry = data.get(mode) if isinstance(data, dict) else None
    if not isinstance(entry, dict) or not isinstance(entry.get("sections"), dict):
        return None
    if not isinstance(entry.get("probe_s"), (int, float)) or entry["probe_s"] <= 0:
        return None
    return entry


def estimate(quick: bool, probe_s: float, path: Path | None = None) -> Estimate:
    """Section seconds expected now: this machine's last run of the same mode, else
    ``REFERENCE``, scaled by ``probe_s`` over the probe of that run."""
    mode = "quick" if quick else "full"
    stored = _stored(path or cache_file(), mode)
    if stored is not None:
        base, source = stored, f"this machine's last {mode} run, {stored.get('date', '?')}"
    else:
        base = REFERENCE.get(mode)
        if base is None or not base["sections"] or base["probe_s"] <= 0:
            return Estimate({}, f"no measured {mode} run to go by")
        source = f"a {mode} run on 2 vCPUs at commit {base['commit']}"
    scale = probe_s / float(base["probe_s"])
    sections = {str(k): float(v) * scale for k, v in base["sections"].items()}
    return Estimate(sections, f"{source}, scaled by this machine's probe: x{scale:.2f}")


def save_times(
    quick: bool, probe_s: float, seconds: dict[str, float], path: Path | None = None
) -> None:
    """Remember this run's section times and probe for the next estimate (sections of earlier
    runs not run now are kept). A cache that cannot be written is skipped silently."""
    path = path or cache_file()
    mode = "quick" if quick else "full"
    try:
        data = json.loads(path.read_text(encoding="utf-8")) if path.is_file() else {}
    except (OSError, ValueError):
        data = {}
    if not isinstance(data, dict):
        data = {}
    previous = _stored(path, mode)
    sections = dict(previous["sections"]) if previous else {}
    if previous:  # earlier sections, brought to this run's probe
        factor = probe_s / float(previous["probe_s"])
        sections = {k: float(v) * factor for k, v in sections.items()}
    sections.update(seconds)
    data[mode] = {"probe_s": probe_s, "sections": sections, "date": time.strftime("%Y-%m-%d")}
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    except OSError:
        pass


def left_line(estimated: Estimate, done: dict[str, float], todo: list[str]) -> str | None:
    """``about N s left``: the remaining sections' estimates, scaled by how the finished ones
    compared with theirs; None when a remaining section has no figure or none is left."""
    rest = estimated.total(todo)
    if not todo or rest is None:
        return None
    expected = sum(estimated.sections.get(name, 0.0) for name in done)
    actual = sum(seconds for name, seconds in done.items() if name in estimated.sections)
    ratio = actual / expected if expected > 0 else 1.0
    return f"about {_minutes(rest * ratio)} left"
