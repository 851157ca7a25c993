"""Base orientations of an object: by category (``suggested``) or on a grid (``random``)."""

from __future__ import annotations

import itertools

from harness.interndata.categories import CATEGORY_ORIENTATIONS

RANDOM_GRID_STEP = 30  # degrees: orientation_mode random -> x, y in {-180, -150, ..., 150}


def suggested_orientations(category: str) -> list[tuple[float, float, float]]:
    """Every base orientation (x, y, z Euler degrees) a category may take, equally likely."""
    rule = CATEGORY_ORIENTATIONS.get(category, {})
    axes = [rule.get(axis, (0,)) for axis in "xyz"]
    return [(float(x), float(y), float(z)) for x, y, z in itertools.product(*axes)]


def random_orientations(step: int = RANDOM_GRID_STEP) -> list[tuple[float, float, float]]:
    """``orientation_mode: random`` on a grid: x, y in [-180, 180) every ``step`` degrees, z 0.

    The reference draws x, y, z ~ U(-180, 180) and then the region's yaw on top; since a uniform
    z composed with any yaw is uniform, z = 0 with a full-circle yaw range is the same
    distribution, and only x, y are discretised.
    """
    angles = [float(a) for a in range(-180, 180, step)]
    return [(x, y, 0.0) for x in angles for y in angles]
