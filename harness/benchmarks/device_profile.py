"""Profile: where the ``mjwarp`` engine's physics step spends its device time, and how many
solver iterations the worlds of a batch take.

Issue 24's GPU path is bound by the device (~1.8 M world-steps/s delivered on an H100 against
the 6.28 M/s MuJoCo Warp reached on a bare FR3 cube scene at 16,384 worlds). This tool plans
real episodes (``harness.benchmarks.engines._plan``), tiles their jobs to the batch sizes asked
for, and runs each batch through ``WorldBatch.run`` as the engine does (one captured CUDA graph
per control step), except that a few control steps run eagerly under Warp's kernel timing
(``wp.timing_begin``): per kernel, the device time of those steps; per physics step of those
steps, each world's solver iterations (``solver_niter``; MuJoCo Warp's solver loop runs until
the last world of the batch converges). It also reruns each batch with solver settings
(``--iterations``, ``--tolerance``) given on the command line and counts how many of the
episodes' outcomes change against the default: the cost of each setting, measured.

    python -m harness.benchmarks.device_profile OUT_DIR --worlds 4096 8192 --rows 20 80 140
"""

from __future__ import annotations

import argparse
import json
import re
import time
from collections import defaultdict
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

# Kernel name prefixes to the stage of ``mjw.step`` they belong to (first match wins).
STAGES: tuple[tuple[str, str], ...] = (
    ("set_ctrl", "harness"),
    ("track_use", "harness"),
    ("record", "harness"),
    ("finger_forces", "harness"),
    ("save_state", "harness"),
    ("advance", "harness"),
    ("load_rungs", "harness"),
    ("_linesearch", "solver: linesearch"),
    ("_update_gradient", "solver: gradient"),
    ("_update_constraint", "solver: constraint"),
    ("_solve", "solver: other"),
    ("_solver", "solver: other"),
    ("mul_m", "solver: other"),
    ("_efc", "constraint rows"),
    ("_friction", "constraint rows"),
    ("_limit", "constraint rows"),
    ("_equality", "constraint rows"),
    ("_contact", "constraint rows"),
    ("_broadphase", "collision"),
    ("_sap", "collision"),
    ("_nxn", "collision"),
    ("_narrowphase", "collision"),
    ("_primitive", "collision"),
    ("_gjk", "collision"),
    ("_ccd", "collision"),
    ("_box", "collision"),
    ("_capsule", "collision"),
    ("_sphere", "collision"),
    ("_plane", "collision"),
    ("_convex", "collision"),
    ("_collision", "collision"),
    ("_cholesky", "smooth: factor / solve"),
    ("_small_cholesky", "smooth: factor / solve"),
    ("_tile_cholesky", "smooth: factor / solve"),
    ("_factor", "smooth: factor / solve"),
)


def kernel_name(raw: str) -> str:
    """A Warp kernel's name without the timing's prefix and the hashes and closure decorations
    Warp adds: ``forward kernel _solve_init_dof__locals__kernel_92449250`` ->
    ``_solve_init_dof``."""
    name = re.sub(r"^(forward|backward) kernel ", "", raw).split("__locals__")[0]
    return re.sub(r"_[0-9a-f]{7,8}$", "", name)


def stage(name: str) -> str:
    """The step stage a kernel belongs to (``STAGES``), else ``other``."""
    for prefix, label in STAGES:
        if name.startswith(prefix):
            return label
    return "other"


@dataclass
class Profile:
    """Device time by kernel over the profiled control steps, and the solver iterations of
    each profiled physics step (over the batch's worlds: the most and the mean)."""

    physics_steps: int = 0
    kernel_ms: dict[str, float] = field(default_factory=lambda: defaultdict(float))
    launches: dict[str, int] = field(default_factory=lambda: defaultdict(int))
    niter_max: list[int] = field(default_factory=list)
    niter_mean: list[float] = field(default_factory=list)

    def by_stage(self) -> dict[str, float]:
        """Device ms per physics step, by stage."""
        out: dict[str, float] = defaultdict(float)
        for name, ms in self.kernel_ms.items():
            out[stage(name)] += ms / max(1, self.physics_steps)
        return dict(sorted(out.items(), key=lambda kv: -kv[1]))

    def summary(self, top: int = 25) -> dict[str, Any]:
        per_step = max(1, self.physics_steps)
        kernels = sorted(self.kernel_ms.items(), key=lambda kv: -kv[1])[:top]
        return {
            "physics_steps": self.physics_steps,
            "device_ms_per_step": sum(self.kernel_ms.values()) / per_step,
            "launches_per_step": sum(self.launches.values()) / per_step,
            "by_stage_ms": self.by_stage(),
            "top_kernels_ms": {
                name: [ms / per_step, self.launches[name] / per_step] for name, ms in kernels
            },
            "solver_iterations_max": _stats(self.niter_max),
            "solver_iterations_mean": _stats(self.niter_mean),
        }


def _stats(values: list[int] | list[float]) -> dict[str, float]:
    import numpy as np

    if not values:
        return {}
    a = np.asarray(values, dtype=float)
    return {"mean": float(a.mean()), "median": float(np.median(a)), "max": float(a.max())}


class Profiler:
    """Replaces ``steps.replay`` and ``stepper`` while active (``installed``): the
    control steps whose index is in ``rows`` run eagerly under kernel timing, the rest as
    replays of the captured graph, as the engine runs them."""

    def __init__(self, rows: set[int]) -> None:
        self.rows = rows
        self.profile = Profile()
        self._eager = False

    @contextmanager
    def installed(self) -> Iterator[Profile]:
        from harness.engines.mjwarp import steps as mjwarp_steps

        replay, stepper = mjwarp_steps.replay, mjwarp_steps.stepper
        mjwarp_steps.replay = self._replay(replay)
        mjwarp_steps.stepper = self._stepper(stepper)
        try:
            yield self.profile
        finally:
            mjwarp_steps.replay, mjwarp_steps.stepper = replay, stepper

    def _stepper(self, original: Callable[..., Any]) -> Callable[..., Any]:
        def make(model: Any, d: Any, use: Any) -> Callable[[], None]:
            step = original(model, d, use)

            def profiled() -> None:
                step()
                if self._eager:  # never while a graph is captured: this reads the device
                    niter = d.solver_niter.numpy()
                    self.profile.physics_steps += 1
                    self.profile.niter_max.append(int(niter.max()))
                    self.profile.niter_mean.append(float(niter.mean()))

            return profiled

        return make

    def _replay(self, original: Callable[..., Any]) -> Callable[..., Any]:
        import warp as wp

        from harness.engines.mjwarp.steps import launch_in_place

        def replay(
            device: str,
            fn: Callable[[], None],
            times: int,
            launch: Any = None,
            per_graph: int = 1,
            looped: bool = False,
        ) -> Any:
            launch = launch or launch_in_place
            if fn.__name__ != "control_step" or not wp.get_device(device).is_cuda or times < 2:
                return original(device, fn, times, launch, per_graph=per_graph, looped=looped)
            fn()
            with wp.ScopedCapture(device=device) as capture:
                fn()
            graph = capture.graph
            assert graph is not None
            for i in range(times - 1):
                if i + 1 in self.rows:
                    self._timed(fn)
                else:
                    launch(graph)
            return None

        return replay

    def _timed(self, fn: Callable[[], None]) -> None:
        import warp as wp

        self._eager = True
        wp.timing_begin(cuda_filter=wp.TIMING_KERNEL)
        try:
            fn()
        finally:
            results = wp.timing_end()
            self._eager = False
        for result in results:
            name = kernel_name(result.name)
            self.profile.kernel_ms[name] += float(result.elapsed)
            self.profile.launches[name] += 1


def plan_jobs(arm: str, obj: str, count: int, workers: int) -> list[Any]:
    """The device jobs of ``count`` planned episodes (seeds 0..count-1) that reach execution."""
    from harness.benchmarks.engines import _plan, _pool, specs, tasks

    with _pool(workers) as pool:
        planned = list(pool.map(_plan, specs(tasks((arm,), (obj,)), count), chunksize=8))
    return [job for _, job in planned if job is not None]


def _outcome_key(outcome: Any) -> tuple[Any, ...]:
    validity = outcome.validity
    return (
        outcome.success,
        outcome.failure_reason,
        bool(validity.valid) if validity else None,
        validity.invalid_reason if validity else None,
    )


def run_case(
    engine: Any, scene: Any, jobs: list[Any], rows: set[int], solver: dict[str, Any]
) -> tuple[dict[str, Any], list[Any]]:
    """One batch of ``jobs`` with the solver settings ``solver`` (``iterations``,
    ``tolerance``; absent: the model's), profiled at control steps ``rows``."""
    batch = engine.batch(scene, jobs[0].task)
    opt = batch.dm.model.opt
    saved = (opt.iterations, float(opt.tolerance.numpy()[0]))
    if "iterations" in solver:
        opt.iterations = int(solver["iterations"])
    if "tolerance" in solver:
        opt.tolerance.fill_(float(solver["tolerance"]))
    profiler = Profiler(rows)
    clock = time.perf_counter()
    try:
        with profiler.installed():
            outcomes = batch.run(jobs)
    finally:
        opt.iterations = saved[0]
        opt.tolerance.fill_(saved[1])
    t = batch.timings
    record = {
        "worlds": len(jobs),
        "solver": solver,
        "wall_s": time.perf_counter() - clock,
        "timings": asdict(t),
        "world_steps_per_s": t.world_steps / max(1e-9, t.physics_s + t.tug_s),
        "profile": profiler.profile.summary(),
    }
    return record, outcomes


def main() -> None:
    from harness.engines.mjwarp.engine import MjwarpEngine
    from harness.episode.scene_cache import get_scene

    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--arm", default="fr3")
    parser.add_argument("--object", default="cube")
    parser.add_argument("--episodes", type=int, default=512, help="planned episodes (seeds)")
    parser.add_argument("--workers", type=int, default=15)
    parser.add_argument("--worlds", type=int, nargs="+", default=[4096])
    parser.add_argument("--rows", type=int, nargs="+", default=[20, 80, 140])
    parser.add_argument("--iterations", type=int, nargs="*", default=[])
    parser.add_argument("--tolerance", type=float, nargs="*", default=[])
    parser.add_argument("--device", default=None)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    jobs = plan_jobs(args.arm, args.object, args.episodes, args.workers)
    engine = MjwarpEngine(args.device)
    scene = get_scene(jobs[0].task, {}).scene
    cases = [{}] + [{"iterations": k} for k in args.iterations]
    cases += [{"tolerance": t} for t in args.tolerance]
    engine.batch(scene, jobs[0].task).run(jobs[:2])  # load the kernels off the clock
    records = []
    for worlds in args.worlds:
        tiled = [jobs[i % len(jobs)] for i in range(worlds)]
        reference: list[Any] = []
        for solver in cases:
            record, outcomes = run_case(engine, scene, tiled, set(args.rows), solver)
            keys = [_outcome_key(o) for o in outcomes[: len(jobs)]]
            if not reference:
                reference = keys
            record["outcomes_changed"] = sum(a != b for a, b in zip(keys, reference, strict=True))
            record["episodes"] = len(jobs)
            records.append(record)
            print(json.dumps(record, default=float), flush=True)
            (args.out / "profile.json").write_text(json.dumps(records, indent=1, default=float))


if __name__ == "__main__":
    main()
