"""Labels of an episode scene do not print over each other (issue 36): each label's anchor keeps
``GAP_M`` from every other, the first placed (the cause) keeps its place, moved ones get a
leader line back to their point."""

from __future__ import annotations

from itertools import combinations
from pathlib import Path

import numpy as np
import pytest
from helpers import FAR, make_task, write_box

from harness.episode import EpisodeSpec, run_episode
from harness.viz.label_layout import GAP_M, LabelLayout
from harness.viz.recording import record_episode


def test_clustered_labels_are_stacked_apart_and_the_first_stays() -> None:
    layout = LabelLayout()
    points = [[0.5, 0.0, 0.1], [0.505, 0.0, 0.1], [0.5, 0.01, 0.11], [0.6, 0.0, 0.1]]
    anchors = [layout.place(p) for p in points]
    assert np.allclose(anchors[0], points[0]) and np.allclose(anchors[3], points[3])
    for a, b in combinations(anchors, 2):
        assert np.linalg.norm(a - b) >= GAP_M - 1e-9
    assert anchors[1][2] == pytest.approx(0.1 + GAP_M)  # stacked straight up
    assert anchors[1][:2] == pytest.approx(points[1][:2])


def test_the_labels_of_a_real_episode_scene_keep_apart(tmp_path: Path) -> None:
    """A reference pick of an object out of reach: the chosen-candidate fallback and the first
    tested candidates all end near the object, with the cause's mark among them."""
    from rerun.chunk import RrdReader

    cube = write_box(tmp_path, (0.04, 0.04, 0.04), "cube")
    task = make_task("fr3", "left", cube, object=FAR)
    result = run_episode(EpisodeSpec(task=task, seed=0), {})
    path = record_episode(result, tmp_path / "episode.rrd", task)
    anchors: dict[str, list[list[float]]] = {}
    leaders = set()
    for chunk in RrdReader(str(path)).stream().to_chunks():
        batch = chunk.to_record_batch()
        names = batch.schema.names
        if chunk.entity_path.endswith("/leaders"):
            leaders.add(chunk.entity_path.removesuffix("/leaders"))
        if "Points3D:labels" in names and "Points3D:show_labels" in names:
            shown = batch.column("Points3D:show_labels").to_pylist()[0]
            if shown and shown[0]:
                anchors[chunk.entity_path] = batch.column("Points3D:positions").to_pylist()[0]
    points = [np.array(p) for group in anchors.values() for p in group]
    assert "/world/cause" in anchors and len(points) >= 3, sorted(anchors)
    for a, b in combinations(points, 2):
        assert np.linalg.norm(a - b) >= GAP_M - 1e-6
    assert leaders, "nothing was close: the scene did not test the layout"
