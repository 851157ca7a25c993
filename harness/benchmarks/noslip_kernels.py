"""Benchmark: the device's noslip pass, MuJoCo Warp's kernel against the block kernel.

For each task model of ``tasks/pick`` (object cube): the object settles on the table (200 CPU
steps from the model's reset), every dof gets a random velocity (so the friction rows are
active), and ``worlds`` copies of that state step on the Warp device, each step one captured
CUDA graph, with the pass off (``noslip_iterations`` 0), with MuJoCo Warp's kernel
(``harness.engines.mjwarp.noslip`` not covering: ``HARNESS_NOSLIP_KERNEL=mjwarp``) and with the
block kernel. Figures per model: ms per physics step of each variant, the pass's cost over the
step without it, and how far the two kernels' states are apart after ``steps`` steps
(largest ``|qacc|`` and ``|qpos|`` difference, the first over the largest ``|qacc|``).

    python -m harness.benchmarks.noslip_kernels OUT_DIR --worlds 1024 --steps 200
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path
from typing import Any

import mujoco
import numpy as np


def settled_state(task_file: str, seed: int = 0) -> tuple[Any, Any]:
    """The task model and a state of it: the object settled on the table, random velocities."""
    from harness.config import load_task
    from harness.sim import Scene

    scene = Scene.for_task(load_task(task_file))
    m = scene.model
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    for _ in range(200):
        mujoco.mj_step(m, d)
    d.qvel[:] += np.random.default_rng(seed).normal(0.0, 0.3, m.nv)
    return m, d


def run_variant(m: Any, d: Any, worlds: int, steps: int, variant: str) -> dict[str, Any]:
    """Step ``worlds`` copies of ``d`` ``steps`` times with one noslip variant (``off``,
    ``mjwarp``, ``block``); ms per step and the final state."""
    import mujoco_warp as mjw
    import warp as wp

    from harness.engines.mjwarp import noslip

    noslip.install()
    os.environ[noslip.KERNEL_ENV] = "mjwarp" if variant == "mjwarp" else "block"
    mw = mjw.put_model(m)
    if variant == "off":
        mw.opt.noslip_iterations = 0
    dw = mjw.put_data(m, d, nworld=worlds, nconmax=64, njmax=256)
    mjw.step(mw, dw)  # load the kernels off the clock (the graph keeps dw's arrays)
    with wp.ScopedCapture() as capture:
        mjw.step(mw, dw)
    wp.synchronize()
    graph = capture.graph
    assert graph is not None
    clock = time.perf_counter()
    for _ in range(steps):
        wp.capture_launch(graph)
    wp.synchronize()
    seconds = time.perf_counter() - clock
    return {
        "kernel_ms": kernel_times(mw, dw),
        "ms_per_step": 1000.0 * seconds / steps,
        "qacc": dw.qacc.numpy(),
        "qpos": dw.qpos.numpy(),
        "nefc": int(dw.nefc.numpy().max()),
    }


def kernel_times(mw: Any, dw: Any, steps: int = 5) -> dict[str, float]:
    """Device ms per step of each kernel of ``steps`` eager steps (Warp's kernel timing), the
    ten largest."""
    import mujoco_warp as mjw
    import warp as wp

    wp.timing_begin(cuda_filter=wp.TIMING_KERNEL)
    for _ in range(steps):
        mjw.step(mw, dw)
    results = wp.timing_end()
    totals: dict[str, float] = {}
    for result in results:
        name = str(result.name).split("__locals__")[0].removeprefix("forward kernel ")
        totals[name] = totals.get(name, 0.0) + float(result.elapsed) / steps
    return dict(sorted(totals.items(), key=lambda kv: -kv[1])[:10])


def compare(task_file: str, worlds: int, steps: int) -> dict[str, Any]:
    """The three variants on one task model, and the two kernels' distance."""
    m, d = settled_state(task_file)
    runs = {v: run_variant(m, d, worlds, steps, v) for v in ("off", "mjwarp", "block")}
    qacc_scale = float(np.abs(runs["mjwarp"]["qacc"]).max())
    return {
        "task": task_file,
        "nv": int(m.nv),
        "nefc": runs["block"]["nefc"],
        "worlds": worlds,
        "steps": steps,
        **{f"ms_{v}": runs[v]["ms_per_step"] for v in runs},
        **{f"kernels_{v}": runs[v]["kernel_ms"] for v in runs},
        "pass_cost_mjwarp": runs["mjwarp"]["ms_per_step"] / runs["off"]["ms_per_step"],
        "pass_cost_block": runs["block"]["ms_per_step"] / runs["off"]["ms_per_step"],
        "qacc_diff_rel": float(np.abs(runs["mjwarp"]["qacc"] - runs["block"]["qacc"]).max())
        / qacc_scale,
        "qpos_diff": float(np.abs(runs["mjwarp"]["qpos"] - runs["block"]["qpos"]).max()),
    }


def main() -> None:
    from harness.config.robot_registry import available_robots, canonical_task_files
    from harness.writes import write_file

    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--worlds", type=int, default=1024)
    parser.add_argument("--steps", type=int, default=200)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    records = []
    task_files = [f for robot in available_robots() for f in canonical_task_files(robot)]
    for task_file in task_files:
        record = compare(str(task_file), args.worlds, args.steps)
        records.append(record)
        print(json.dumps(record), flush=True)
        write_file(args.out / "noslip_kernels.json", json.dumps(records, indent=1))


if __name__ == "__main__":
    main()
