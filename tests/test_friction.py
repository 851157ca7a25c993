"""Friction that means what it says: an object's contacts with the pads and the table use the
object's sliding friction (``harness.sim.composition``; docs/config.md, Friction).

MuJoCo combines two geoms' friction by maximum, so before this rule the pads' 1.5 won every
object-pad contact and ``object.friction`` changed nothing (the same lift heights within 0.1 mm
at 0.05 and 1.5, issue 16).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from test_scene import make_task, write_box

from harness.config import TaskConfig, apply_overrides, load_task
from harness.episode import EpisodeSpec, run_episode
from harness.sim import Scene
from harness.sim.composition import OBJECT_PRIORITY, PAD_SUFFIX

TASKS_DIR = Path(__file__).resolve().parents[1] / "tasks" / "pick"


@pytest.fixture(scope="module")
def cube(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_box(tmp_path_factory.mktemp("friction_cube"), (0.04, 0.04, 0.04), "cube")


def test_object_geoms_outrank_robot_and_table_and_pads_pair_with_object_friction(
    cube: Path,
) -> None:
    """Object geoms have the higher priority; each (pad, object geom) pair carries the object's
    sliding friction and the pad's torsional friction (MuJoCo's maximum of the two)."""
    task = make_task("split_aloha", "left", cube, object={"friction": 0.3})
    scene = Scene.build(task.robot, task.objects, task.physics)
    m = scene.model
    objects = scene.geom_object >= 0
    assert (m.geom_priority[objects] == OBJECT_PRIORITY).all()
    assert (m.geom_priority[~objects] < OBJECT_PRIORITY).all()
    pads = [g for g in range(m.ngeom) if m.geom(g).name.endswith(PAD_SUFFIX)]
    assert len(pads) == 4  # two fingers per arm, two arms
    assert m.npair == len(pads) * int(objects.sum())
    for k in range(m.npair):
        pad, obj = int(m.pair_geom1[k]), int(m.pair_geom2[k])
        assert pad in pads and objects[obj]
        assert m.pair_friction[k, 0] == m.pair_friction[k, 1] == pytest.approx(0.3)
        assert m.pair_friction[k, 2] == max(m.geom_friction[pad, 1], m.geom_friction[obj, 1])
        assert m.pair_dim[k] == max(m.geom_condim[pad], m.geom_condim[obj])


def _with_friction(task: TaskConfig, friction: float) -> TaskConfig:
    return apply_overrides(task, {"object.friction": friction, "objects.0.mass": 0.3})


def test_object_friction_decides_a_heavy_pick() -> None:
    """FR3 canonical task, a 0.3 kg cube, the same seeds: at friction 0.1 the cube slips out of
    the ~5 N per pad grip (needs mu >= m g / (2 F) ~ 0.3), at 1.5 it is lifted. Measured on
    seeds 0-5: 0/6 at 0.1 (dropped, lift 0.8 mm), 6/6 at 1.5 (lift 91-184 mm)."""
    task = load_task(TASKS_DIR / "fr3.yaml")
    cache: dict = {}
    for seed in (0, 1):
        low = run_episode(EpisodeSpec(task=_with_friction(task, 0.1), seed=seed), cache).row
        high = run_episode(EpisodeSpec(task=_with_friction(task, 1.5), seed=seed), cache).row
        assert (low["object_friction"], high["object_friction"]) == (0.1, 1.5)
        assert not low["success"] and low["failure_reason"] == "dropped", low["error_message"]
        assert low["lift_height_m"] < 0.005
        assert high["success"], high["error_message"]
        assert high["lift_height_m"] > 0.05
