"""Shared test fixtures: paths to the project's and the shared example data."""

from __future__ import annotations

import os
from pathlib import Path

# Offscreen rendering without a display (must be set before mujoco is first imported).
os.environ.setdefault("MUJOCO_GL", "egl")

import pytest

PROJECT_ROOT = Path(__file__).resolve().parents[1]
SHARED_DIR = PROJECT_ROOT.parent / "shared"
EXAMPLES_DIR = SHARED_DIR / "datasets" / "interndata-examples"
EXAMPLE_OBJECTS_DIR = EXAMPLES_DIR / "objects"

NO_EXAMPLES = "../shared/datasets/interndata-examples is absent (InternDataEngine example data)"


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
