"""Shared test fixtures: the InternDataEngine example data (``helpers.INTERNDATA_EXAMPLES``:
``PICK_HARNESS_EXAMPLES`` or ``../shared/datasets/interndata-examples``), skipping with a reason
that names the folder and where to get it when it is absent."""

from __future__ import annotations

import os
from collections import Counter
from pathlib import Path
from typing import Any

# Offscreen rendering without a display (must be set before mujoco is first imported).
os.environ.setdefault("MUJOCO_GL", "egl")

import pytest
from helpers import INTERNDATA_EXAMPLES as EXAMPLES_DIR
from helpers import NO_INTERNDATA_EXAMPLES as NO_EXAMPLES
from hypothesis import settings

EXAMPLE_OBJECTS_DIR = EXAMPLES_DIR / "objects"

# A longer bug hunt for the fuzz tests: ``pytest --hypothesis-profile=bughunt`` (each fuzz test
# runs at least its own example count, more under this profile).
settings.register_profile("bughunt", max_examples=5000)


def example_object_dirs() -> list[Path]:
    """Folders holding Aligned_obj.usd + Aligned_grasp_sparse.npy, sorted; [] when absent."""
    if not EXAMPLE_OBJECTS_DIR.is_dir():
        return []
    return sorted(p.parent for p in EXAMPLE_OBJECTS_DIR.glob("*/*/Aligned_grasp_sparse.npy"))


@pytest.fixture
def examples_dir() -> Path:
    """The InternDataEngine example folder; skips the test when it is absent."""
    if not EXAMPLES_DIR.is_dir():
        pytest.skip(NO_EXAMPLES)
    return EXAMPLES_DIR


@pytest.fixture
def example_objects() -> list[Path]:
    """Every example object folder; skips the test when the data is absent."""
    dirs = example_object_dirs()
    if not dirs:
        pytest.skip(NO_EXAMPLES)
    return dirs


def pytest_terminal_summary(terminalreporter: Any) -> None:
    """The skipped tests' reasons, one line each with its count (``-rs`` lists every test:
    81 lines of the same missing folder), so a skip count never comes without its cause."""
    reasons: Counter[str] = Counter()
    for report in terminalreporter.stats.get("skipped", []):
        longrepr = getattr(report, "longrepr", None)
        if isinstance(longrepr, tuple) and len(longrepr) == 3:
            reasons[str(longrepr[2]).removeprefix("Skipped: ")] += 1
    if reasons:
        terminalreporter.write_sep("-", "skipped, by reason")
        for reason, count in reasons.most_common():
            terminalreporter.write_line(f"{count:4d} skipped: {reason}")
