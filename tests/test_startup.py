"""What a command and a sweep worker import before they do anything (issue 56: "trivial commands
are slow", "every pool spends 40-90 s starting workers" on a loaded 2-core box).

Import time is measured with ``python -X importtime`` (docs/reliability.md has the figures); the
tests pin which heavy modules each start-up leaves out, in a fresh interpreter each.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("mujoco", "trimesh", "scipy", "matplotlib.pyplot", "placo", "toppra", "rerun")


def imported_after(code: str) -> dict[str, str]:
    """The heavy modules in ``sys.modules`` after ``code`` runs in a fresh interpreter, each
    with its module type's name (``DeferredModule``: a placeholder, not yet imported)."""
    probe = (
        f"{code}\nimport json, sys\n"
        f"print(json.dumps({{m: type(sys.modules[m]).__name__ for m in {HEAVY!r} "
        "if m in sys.modules}))"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe], cwd=ROOT, capture_output=True, text=True, check=True
    )
    return json.loads(done.stdout.splitlines()[-1])


def test_help_imports_no_simulator_planner_or_plotting() -> None:
    code = "from harness.cli import build_parser\nbuild_parser().format_help()"
    assert imported_after(code) == {}


def test_a_worker_imports_pyplot_only_when_something_plots() -> None:
    """toppra imports pyplot for plotting helpers the harness never calls: a worker's imports
    leave a placeholder, and the first use imports the real module."""
    worker = "from harness.episode import run_episode\nfrom harness.runs.worker import execute"
    modules = imported_after(worker)
    assert {"mujoco", "toppra", "placo"} <= set(modules)  # what an episode needs, imported
    assert modules["matplotlib.pyplot"] == "DeferredModule"
    plots = imported_after(
        f"{worker}\nimport matplotlib\nmatplotlib.use('Agg')\nimport matplotlib.pyplot as plt\n"
        "figure = plt.figure()\nassert type(figure).__name__ == 'Figure'"
    )
    assert plots["matplotlib.pyplot"] == "module"  # the real one, in its place
