"""The device's noslip pass (harness.engines.mjwarp.noslip) on Warp's CPU device: the block
kernel gives MuJoCo Warp's kernel's states, the pass acts on them, and the models it does not
cover keep MuJoCo Warp's kernel. On the CPU device a block is one thread, so this pins the row
logic; the spread over a GPU block is compared on the device by
``python -m harness.benchmarks.noslip_kernels`` (docs/engines.md). Skipped without the 'gpu'
extra (as tests/test_engines.py)."""

from __future__ import annotations

import importlib.util
import os
from collections.abc import Iterator

import numpy as np
import pytest

HAS_WARP = importlib.util.find_spec("mujoco_warp") is not None
needs_warp = pytest.mark.skipif(not HAS_WARP, reason="needs the 'gpu' extra (pip install .[gpu])")


@pytest.fixture
def kernel_env() -> Iterator[None]:
    """Restores ``HARNESS_NOSLIP_KERNEL`` after a test that sets it."""
    saved = os.environ.get("HARNESS_NOSLIP_KERNEL")
    yield
    if saved is None:
        os.environ.pop("HARNESS_NOSLIP_KERNEL", None)
    else:
        os.environ["HARNESS_NOSLIP_KERNEL"] = saved


def _qacc_after(task_file: str, variant: str, steps: int = 20) -> np.ndarray:
    """Two worlds of the settled, shaken task model after ``steps`` steps on the CPU device."""
    import mujoco_warp as mjw
    import warp as wp

    from harness.benchmarks.noslip_kernels import settled_state
    from harness.engines.mjwarp import noslip

    noslip.install()
    os.environ[noslip.KERNEL_ENV] = "mjwarp" if variant == "mjwarp" else "block"
    m, d = settled_state(task_file)
    with wp.ScopedDevice("cpu"):
        mw = mjw.put_model(m)
        if variant == "off":
            mw.opt.noslip_iterations = 0
        dw = mjw.put_data(m, d, nworld=2, nconmax=128, njmax=256)
        for _ in range(steps):
            mjw.step(mw, dw)
        return dw.qacc.numpy().copy()


@pytest.mark.gpu
@needs_warp
@pytest.mark.parametrize("task_file", ["tasks/pick/fr3.yaml", "tasks/pick/split_aloha_left.yaml"])
def test_block_kernel_gives_mujoco_warps_states(task_file: str, kernel_env: None) -> None:
    """FR3 (seven friction-loss joints) and Split ALOHA left (four, 22 dofs), the cube settled
    on the table and every dof shaken: after 20 steps the block kernel's ``qacc`` equals MuJoCo
    Warp's kernel's, and differs from the step without the pass by more than 0.01."""
    block = _qacc_after(task_file, "block")
    reference = _qacc_after(task_file, "mjwarp")
    off = _qacc_after(task_file, "off")
    np.testing.assert_allclose(block, reference, rtol=1e-5, atol=1e-5)
    assert np.abs(off - reference).max() > 0.01


@pytest.mark.gpu
@needs_warp
def test_covers_the_harness_models_and_not_the_others(kernel_env: None) -> None:
    """Every canonical task model (dense Jacobian, elliptic cones) runs the block kernel; a
    pyramidal model, or ``HARNESS_NOSLIP_KERNEL=mjwarp``, keeps MuJoCo Warp's."""
    import mujoco
    import mujoco_warp as mjw
    import warp as wp

    from harness.config import load_task
    from harness.config.robot_registry import available_robots, canonical_task_files
    from harness.engines.mjwarp import noslip
    from harness.sim import Scene

    os.environ.pop(noslip.KERNEL_ENV, None)
    files = [f for robot in available_robots() for f in canonical_task_files(robot)]
    assert len(files) == 5
    with wp.ScopedDevice("cpu"):
        for task_file in files:
            model = Scene.for_task(load_task(task_file)).model
            assert noslip.covers(mjw.put_model(model)), task_file
        pyramidal = mujoco.MjModel.from_xml_string(
            "<mujoco><option cone='pyramidal' noslip_iterations='3'/><worldbody>"
            "<body><freejoint/><geom size='0.1'/></body></worldbody></mujoco>"
        )
        assert not noslip.covers(mjw.put_model(pyramidal))
        os.environ[noslip.KERNEL_ENV] = "mjwarp"
        assert not noslip.covers(mjw.put_model(model))
