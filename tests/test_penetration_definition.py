"""Table penetration: one definition on both engines, checked on real FR3 states.

The CPU executor measures ``mj_geomDistance``'s signed distance of each moving robot geom to the
table slab; the device measures the face-normal overlap (``kernels.slab_depth``), which
``harness.pick.penetration.slab_overlap`` computes on the CPU. On the FR3 cube episodes of issue
34 that the CPU calls ``table_penetration`` and MJWarp valid (``downward 160``), both read the
same depth at every control step of the CPU's motion: the engines' gap there comes from the
motion, not from the measure (docs/engines.md).
"""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest
from helpers import TASKS_DIR

from harness.config import apply_overrides, load_task
from harness.episode import EpisodeSpec, run_episode, table_verdict
from harness.pick import penetration
from harness.runs.expansion import point_overrides

HAS_WARP = importlib.util.find_spec("mujoco_warp") is not None
# Issue 34's sweep (seed 0, point downward 160): an episode whose CPU depth was 2.52 mm
# (``table_penetration``) and MJWarp's 1.82 mm (valid), measured on an H100 on 2026-11-27.
SEED = 6569863346532939966


def _states(monkeypatch: pytest.MonkeyPatch) -> tuple[dict, list[tuple[np.ndarray, ...]]]:
    """The episode's row and, per depth call, (signed-distance depth per geom, slab overlap
    per geom, geom positions, geom rotations) of the CPU executor's motion."""
    states: list[tuple[np.ndarray, ...]] = []
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
        states.append(
            (
                inside,
                self.slab_inside(data),
                data.geom_xpos[self.geoms].copy(),
                data.geom_xmat[self.geoms].copy(),
            )
        )
        return inside

    monkeypatch.setattr(penetration.TablePenetration, "_inside", both)
    monkeypatch.setattr(table_verdict, "replay_on_physical_table", marked_replay)
    base = load_task(TASKS_DIR / "fr3.yaml")
    task = apply_overrides(base, point_overrides(base, {"pick.approach_filter": ["downward", 160]}))
    row = run_episode(EpisodeSpec(task=task, seed=SEED)).row
    return row, states


def test_the_slab_overlap_reads_the_signed_distance_depth_on_a_real_episode(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    row, states = _states(monkeypatch)
    assert row["invalid_reason"] == "table_penetration"
    assert row["table_penetration_m"] == pytest.approx(0.00252, abs=5e-5)
    first_signed, first_slab = states[0][0], states[0][1]
    deepest_signed = max(float(np.max(s - first_signed, initial=0.0)) for s, *_ in states)
    deepest_slab = max(float(np.max(b - first_slab, initial=0.0)) for _, b, *_ in states)
    assert deepest_signed == pytest.approx(row["table_penetration_m"], abs=1e-9)
    assert deepest_slab == pytest.approx(deepest_signed, abs=1e-6)
    pressed = [(s, b) for s, b, *_ in states if np.any(s > 0)]
    assert pressed  # the fingers were in the slab on some steps
    for s, b in pressed:  # the bound never reads less where the geom is in the slab
        assert np.all(b[s > 0] >= s[s > 0] - 1e-9)


@pytest.mark.slow
@pytest.mark.gpu
@pytest.mark.skipif(not HAS_WARP, reason="needs the 'gpu' extra (pip install .[gpu])")
def test_the_device_function_is_the_cpu_slab_overlap(monkeypatch: pytest.MonkeyPatch) -> None:
    """``kernels.slab_depth`` on Warp's CPU device, on the episode's geom poses: the CPU
    function's values (float32)."""
    import warp as wp

    from harness.engines.mjwarp import kernels
    from harness.episode.scene_cache import get_scene

    _, states = _states(monkeypatch)
    base = load_task(TASKS_DIR / "fr3.yaml")
    meter = penetration.TablePenetration(get_scene(base, {}).scene)
    m = meter.model
    table = m.geom_pos[meter.table].astype(np.float32)
    half = m.geom_size[meter.table].astype(np.float32)

    @wp.kernel
    def depth_of(
        pos: wp.array(dtype=wp.vec3),
        rot: wp.array(dtype=wp.mat33),
        box: wp.array(dtype=wp.vec3),
        radial: wp.array(dtype=wp.float32),
        rounding: wp.array(dtype=wp.float32),
        offset: wp.array(dtype=wp.vec3),
        table: wp.vec3,
        table_half: wp.vec3,
        out: wp.array(dtype=wp.float32),
    ):
        g = wp.tid()
        out[g] = kernels.slab_depth(
            pos[g], rot[g], box[g], radial[g], rounding[g], offset[g], table, table_half
        )

    n = len(meter.geoms)
    for _, slab, pos, xmat in states[:: max(1, len(states) // 20)]:
        out = wp.zeros(n, dtype=wp.float32, device="cpu")
        wp.launch(
            depth_of, dim=n, device="cpu",
            inputs=[
                wp.array(pos.astype(np.float32), dtype=wp.vec3, device="cpu"),
                wp.array(xmat.reshape(-1, 3, 3).astype(np.float32), dtype=wp.mat33, device="cpu"),
                wp.array(meter.box_half.astype(np.float32), dtype=wp.vec3, device="cpu"),
                wp.array(meter.radial.astype(np.float32), dtype=wp.float32, device="cpu"),
                wp.array(meter.round.astype(np.float32), dtype=wp.float32, device="cpu"),
                wp.array(meter.offset.astype(np.float32), dtype=wp.vec3, device="cpu"),
                wp.vec3(*table), wp.vec3(*half), out,
            ],
        )  # fmt: skip
        assert np.allclose(out.numpy(), slab, atol=2e-6)
