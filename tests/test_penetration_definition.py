"""Table penetration, checked on a real FR3 episode: the executor measures ``mj_geomDistance``'s
signed distance of each moving robot geom to the table slab, and the row's depth is the deepest
a geom went past where it stood at the start of the motion (``TablePenetration.depth``).
"""

from __future__ import annotations

import numpy as np
import pytest
from helpers import TASKS_DIR

from harness.config import apply_overrides, load_task
from harness.episode import EpisodeSpec, run_episode, table_verdict
from harness.pick import penetration
from harness.runs.expansion import point_overrides

# Issue 34's sweep (seed 0, point downward 160): an episode whose depth is 2.52 mm
# (``table_penetration``).
SEED = 6569863346532939966


def _states(monkeypatch: pytest.MonkeyPatch) -> tuple[dict, list[np.ndarray]]:
    """The episode's row and, per depth call, the signed-distance depth per geom of the
    executor's motion."""
    states: list[np.ndarray] = []
    signed = penetration.TablePenetration._inside
    replaying = [False]  # the table verdict's replay (issue 33) is a second motion: not counted
    replay = table_verdict.replay_on_physical_table

    def marked_replay(*args, **kwargs):
        replaying[0] = True
        return replay(*args, **kwargs)

    def both(self: penetration.TablePenetration, data) -> np.ndarray:
        inside = signed(self, data)
        if replaying[0]:
            return inside
        states.append(inside)
        return inside

    monkeypatch.setattr(penetration.TablePenetration, "_inside", both)
    monkeypatch.setattr(table_verdict, "replay_on_physical_table", marked_replay)
    base = load_task(TASKS_DIR / "fr3.yaml")
    task = apply_overrides(base, point_overrides(base, {"pick.approach_filter": ["downward", 160]}))
    row = run_episode(EpisodeSpec(task=task, seed=SEED)).row
    return row, states


def test_the_rows_depth_is_the_deepest_signed_distance_past_the_start(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    row, states = _states(monkeypatch)
    assert row["invalid_reason"] == "table_penetration"
    assert row["table_penetration_m"] == pytest.approx(0.00252, abs=5e-5)
    first = states[0]
    deepest = max(float(np.max(s - first, initial=0.0)) for s in states)
    assert deepest == pytest.approx(row["table_penetration_m"], abs=1e-9)
    assert any(np.any(s > 0) for s in states)  # the fingers were in the slab on some steps
