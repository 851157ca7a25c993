"""Benchmark section ``episodes``: wall time of whole pick episodes, and its ratio to bare physics.

Per robot, the canonical task (``tasks/pick/<robot>.yaml``, the default cube) runs ``n`` seeded
episodes on one cached scene (the scene build is excluded: a sweep worker pays it once). Each
episode's wall time is split into planning (candidate selection, feasibility, plan, timing) and
simulation (the executed control loop). The ratio's denominator is measured in the same run on
the same episode: the scene is reset with the same seed and the episode's logged actuator
commands are replayed with ``mj_step(m, d, n)`` per servo chunk -- the same physics steps with
nothing of the harness around them.

The whole section runs pinned to one CPU (the least busy one at its start): the target is per
core, and a sweep runs one episode per core.

The validity phase (``pick.validity: on``, the default; hold and tug after the reference
verdict) is part of the episode and of its replay: its hold and tug steps are logged like the
execution's (the replay steps them with the held controls, without the tug forces and the state
restores between tug rungs: the same number of steps of the same model). Its own wall time is
reported as its own figure.

Targets (FR3, ik mode, TOPP-RA): median episode under 0.2 s, wall / bare physics under 2.2.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from harness.benchmarks.framework import Figure, figure
from harness.benchmarks.machine import one_core
from harness.config import load_task
from harness.config.robot_registry import TASKS_DIR, available_robots, canonical_task_files
from harness.episode import SETTLE_TIME_S, EpisodeSpec, run_episode

SECTION = "episodes"
WALL_TARGET_S = {"fr3": 0.2}
RATIO_TARGET = {"fr3": 2.2}


def bare_physics_time(result: Any, seed: int) -> float:
    """Seconds of ``mj_step`` alone for the episode's physics: reset with the same seed, then
    the settling steps and the logged commands (the warm-up steps first), chunk by chunk."""
    scene = result.scene
    task = result.spec.task
    scene.reset(task, np.random.default_rng(seed), settle_time=0.0)
    m, d = scene.model, scene.data
    settle = int(result.timings.get("settle_steps", round(SETTLE_TIME_S / m.opt.timestep)))
    log = result.ctrl_log or []
    start = time.perf_counter()
    mujoco.mj_step(m, d, settle)
    for steps, ctrl in log:
        d.ctrl[:] = ctrl
        mujoco.mj_step(m, d, steps)
    return time.perf_counter() - start


def benchmark_tasks() -> list[str]:
    """The first canonical task file (stem) of every bundled robot (the registry's list)."""
    return [canonical_task_files(name)[0].stem for name in available_robots()]


def run(quick: bool) -> list[Figure]:
    with one_core() as pinned:
        figures: list[Figure] = []
        for name in benchmark_tasks():
            figures.extend(_task_figures(name, 8 if quick else 30, pinned))
        return figures


@dataclass
class EpisodeTimes:
    """Per-episode wall time and its parts for one canonical task (lists in seed order)."""

    walls: list[float] = field(default_factory=list)
    setups: list[float] = field(default_factory=list)
    plans: list[float] = field(default_factory=list)
    sims: list[float] = field(default_factory=list)
    validity: list[float] = field(default_factory=list)
    ratios: list[float] = field(default_factory=list)
    bares: list[float] = field(default_factory=list)
    steps: list[float] = field(default_factory=list)
    successes: int = 0


def _measure(task: Any, count: int) -> EpisodeTimes:
    """Run ``count`` seeded episodes on one cached scene (built and warmed up first)."""
    cache: dict[str, Any] = {}
    run_episode(EpisodeSpec(task=task, seed=10_000), cache)  # build the scene, warm up
    times = EpisodeTimes()
    for seed in range(count):
        result = run_episode(EpisodeSpec(task=task, seed=seed, log_ctrl=True), cache)
        row = result.row
        times.successes += bool(row["success"])
        times.walls.append(row["wall_time_s"])
        times.setups.append(result.timings.get("setup_s", float("nan")))
        times.plans.append(result.timings.get("plan_s", float("nan")))
        times.sims.append(result.timings.get("sim_s", float("nan")))
        times.validity.append(result.timings.get("validity_s", float("nan")))
        if result.ctrl_log:
            bare = bare_physics_time(result, seed)
            times.bares.append(bare)
            times.ratios.append(row["wall_time_s"] / bare)
            # The logged steps: warm-up, execution and the validity phase.
            times.steps.append(
                sum(steps for steps, _ in result.ctrl_log) + result.timings.get("settle_steps", 0.0)
            )
    return times


def _task_figures(name: str, count: int, pinned: str) -> list[Figure]:
    """Wall time and its parts for ``count`` seeded episodes of one canonical task."""
    task = load_task(TASKS_DIR / f"{name}.yaml")
    times = _measure(task, count)
    walls, steps, bares, successes = times.walls, times.steps, times.bares, times.successes
    label = f"{name} ({task.pick.test_mode}, {task.pick.timing})"
    extra = {
        "successes": successes,
        "episodes": count,
        "wall_p90_s": float(np.quantile(walls, 0.9)),
        "mean_physics_steps": float(np.mean(steps)) if steps else None,
        "bare_steps_per_s": float(np.sum(steps) / np.sum(bares)) if bares else None,
        "pinned": pinned,
    }
    mean_steps = f"{np.mean(steps):.0f}" if steps else "?"
    return [
        figure(
            SECTION,
            f"{label}: episode wall time",
            walls,
            "s",
            target=WALL_TARGET_S.get(name),
            notes=f"{successes}/{count} successful; one core ({pinned}); scene build excluded",
            extra=extra,
        ),
        figure(
            SECTION,
            f"{label}: setup (reset + settle) per episode",
            times.setups,
            "s",
            notes="placement, home + noise, settling physics",
        ),
        figure(
            SECTION,
            f"{label}: planning per episode",
            times.plans,
            "s",
            notes="candidates, feasibility tests, plan, timing (episodes that reached execution)",
        ),
        figure(
            SECTION,
            f"{label}: simulation per episode",
            times.sims,
            "s",
            notes="the executed control loop: controller, physics, checks, trace "
            "(the validity phase included)",
        ),
        figure(
            SECTION,
            f"{label}: validity phase per episode",
            times.validity,
            "s",
            notes="after the reference verdict: rest of the motion, rest, 1 s hold, tug ladder",
        ),
        figure(
            SECTION,
            f"{label}: bare mj_step per episode",
            bares,
            "s",
            notes=f"same seed, settle + logged commands replayed; {mean_steps} steps on average",
        ),
        figure(
            SECTION,
            f"{label}: wall / bare mj_step",
            times.ratios,
            "x",
            target=RATIO_TARGET.get(name),
            notes="per episode, same run: whole episode over its physics alone",
        ),
    ]
