"""Labels of an episode scene that do not collide.

Rerun draws a point's label at the point, so the labels of things that lie close together (the
chosen pre-grasp and grasp, a few candidates' TCPs around the object, the cause's mark) print
over each other. ``LabelLayout`` places each label's anchor in turn: where it belongs if that is
at least ``gap_m`` from every anchor placed before, else stacked upwards (+z, the scene's up) in
steps of ``gap_m`` until it is; a thin leader line joins a moved anchor to its point. The first
placed keeps its place, so the scene places the most important labels first (the cause, the
chosen targets, then candidates).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

GAP_M = 0.03  # chosen, no public source: two 12 px labels apart at the viewer's default zoom
MAX_STEPS = 40  # stacked this high at most (1.2 m), then placed anyway


class LabelLayout:
    """Anchors of the labels placed so far in one scene."""

    def __init__(self, gap_m: float = GAP_M) -> None:
        self.gap_m = gap_m
        self.anchors: list[np.ndarray] = []

    def _free(self, point: np.ndarray) -> bool:
        return all(np.linalg.norm(point - a) >= self.gap_m - 1e-9 for a in self.anchors)

    def place(self, point: Sequence[float] | np.ndarray) -> np.ndarray:
        """The anchor of one label at ``point``: the point itself when free, else above it."""
        anchor = np.array(point, dtype=float)
        for _ in range(MAX_STEPS):
            if self._free(anchor):
                break
            anchor = anchor + np.array([0.0, 0.0, self.gap_m])
        self.anchors.append(anchor)
        return anchor


def log_labels(
    rec: Any,
    entity: str,
    points: np.ndarray,
    labels: list[str],
    color: Sequence[int],
    layout: LabelLayout | None,
) -> None:
    """Labelled points at their anchors (``layout``, else at the points), static; a leader line
    (``<entity>/leaders``) from each moved anchor back to its point."""
    import rerun as rr

    points = np.asarray(points, dtype=float).reshape(-1, 3)
    anchors = np.array([layout.place(p) for p in points]) if layout is not None else points
    rec.log(
        entity,
        rr.Points3D(anchors, colors=[tuple(color)], radii=[0.001], labels=labels, show_labels=True),
        static=True,
    )
    moved = [
        [p, a] for p, a in zip(points, anchors, strict=True) if not np.allclose(p, a, atol=1e-9)
    ]
    if moved:
        rec.log(
            f"{entity}/leaders",
            rr.LineStrips3D(moved, colors=[tuple(color)], radii=[0.0005]),
            static=True,
        )
