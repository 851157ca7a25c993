"""Benchmark: the ``mjwarp`` engine against the ``mujoco`` engine, agreement and throughput.

The same episodes (the five arms of ``tasks/pick``, objects cube and banana, seeds 0..n-1) run
twice on this box: CPU-only (``mujoco``, one process per core, as ``harness sweep`` runs) and
with the physics on the GPU (``mjwarp``): the same worker processes plan each episode and make
its control schedule (``harness.engines.schedule``) and send the job (``DeviceJob``) to this
process, which steps each task model's jobs as one batch of worlds and judges them with the same
verdict terms. Figures: episodes per hour end to end on both paths and their ratio; where the
GPU path's time goes (planning pool, upload, physics, tug, download); physics world-steps/s at
the batch size used; and agreement per (arm, object): the reference outcome (success and
failure reason) and the validity verdict of each executed episode on both engines.
"""

from __future__ import annotations

import dataclasses
import json
import math
import multiprocessing
import os
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from harness.benchmarks.framework import Figure, figure
from harness.config import TaskConfig, apply_overrides, load_task
from harness.config.robot_registry import available_robots, canonical_task_files
from harness.engines import Execution, ExecutionJob, register_engine
from harness.objects.assets import repo_root
from harness.pick.outcome import PickOutcome
from harness.pick.validity import validity_enabled
from harness.runs.expansion import point_overrides

SECTION = "engines"
# Every canonical task file (tasks/pick/<robot>[_arm].yaml) of every bundled robot.
ARMS = tuple(p.stem for robot in available_robots() for p in canonical_task_files(robot))
OBJECTS = ("cube", "banana")
TARGET_RATIO = 8.0
TARGET_RATE = 3_000_000.0


class _Collector:
    """An engine that keeps the job (as a ``DeviceJob``) instead of executing it."""

    name = "collect"

    def __init__(self) -> None:
        self.jobs: list[Any] = []

    def execute(self, job: ExecutionJob) -> Execution:
        from harness.engines.schedule import device_job

        self.jobs.append(device_job(job))
        outcome = PickOutcome(failure_reason="error", message="collected for the device")
        return Execution(outcome, validity_enabled(job.task.pick))


_COLLECTOR = _Collector()
_SCENES: dict[Any, Any] = {}


def _plan(spec: Any) -> tuple[dict[str, Any], Any]:
    """Worker: plan one episode; its row (when it ended before execution) and its job."""
    from harness.episode import run_episode

    register_engine(_COLLECTOR)
    _COLLECTOR.jobs.clear()
    row = run_episode(dataclasses.replace(spec, engine="collect"), _SCENES).row
    return row, (_COLLECTOR.jobs[0] if _COLLECTOR.jobs else None)


def _cpu(spec: Any) -> dict[str, Any]:
    """Worker: one whole episode on the mujoco engine."""
    from harness.episode import run_episode

    return run_episode(spec, _SCENES).row


def tasks(arms: tuple[str, ...] = ARMS, objects: tuple[str, ...] = OBJECTS) -> list[TaskConfig]:
    out = []
    for arm in arms:
        task = load_task(repo_root() / "tasks" / "pick" / f"{arm}.yaml")
        for obj in objects:
            out.append(apply_overrides(task, point_overrides(task, {"object.mesh": obj})))
    return out


def specs(task_list: list[TaskConfig], seeds: int) -> list[Any]:
    from harness.episode import EpisodeSpec

    return [EpisodeSpec(task=t, seed=s, episode_index=s) for t in task_list for s in range(seeds)]


def _pool(workers: int) -> ProcessPoolExecutor:
    return ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"))


def run_cpu(all_specs: list[Any], workers: int) -> tuple[list[dict[str, Any]], float]:
    with _pool(workers) as pool:
        list(pool.map(_cpu, all_specs[:workers]))  # start the workers, build their scenes
        start = time.perf_counter()
        rows = list(pool.map(_cpu, all_specs, chunksize=4))
        return rows, time.perf_counter() - start


def run_gpu(all_specs: list[Any], workers: int, device: str) -> dict[str, Any]:
    """Plan on the pool, then one batch per task model on the device; outcomes and timings."""
    from harness.engines.mjwarp_engine import MjwarpEngine
    from harness.episode.scene_cache import get_scene

    with _pool(workers) as pool:
        list(pool.map(_plan, all_specs[:workers]))
        start = time.perf_counter()
        planned = list(pool.map(_plan, all_specs, chunksize=4))
        plan_s = time.perf_counter() - start
    engine = MjwarpEngine(device)
    groups: dict[str, list[int]] = {}
    for i, (_, job) in enumerate(planned):
        if job is not None:
            groups.setdefault(job.task.model_dump_json(), []).append(i)
    scenes: dict[Any, Any] = {}
    outcomes: dict[int, PickOutcome] = {}
    totals = {
        "upload_s": 0.0, "physics_s": 0.0, "tug_s": 0.0, "download_s": 0.0,
        "tug_rounds": 0.0, "tug_rungs": 0.0,
    }  # fmt: skip
    steps, worlds = 0, 0
    compile_s = 0.0
    start = time.perf_counter()
    for index_list in groups.values():
        jobs = [planned[i][1] for i in index_list]
        scene = get_scene(jobs[0].task, scenes).scene
        if compile_s == 0.0:  # first batch of the run: kernels load (and compile) here
            clock = time.perf_counter()
            engine.execute_many(scene, jobs[:1])
            compile_s = time.perf_counter() - clock
            start += compile_s
        result, timings = engine.execute_many(scene, jobs)
        for i, outcome in zip(index_list, result, strict=True):
            outcomes[i] = outcome
        for key in totals:
            totals[key] += getattr(timings, key)
        steps += timings.world_steps
        worlds = max(worlds, len(jobs))
    gpu_s = time.perf_counter() - start
    return {
        "planned": planned, "outcomes": outcomes, "plan_s": plan_s, "gpu_s": gpu_s,
        "compile_s": compile_s, "world_steps": steps, "max_batch": worlds, **totals,
    }  # fmt: skip


def agreement(cpu_rows: list[dict[str, Any]], gpu: dict[str, Any]) -> list[dict[str, Any]]:
    """One record per executed episode: both engines' reference and validity verdicts."""
    records = []
    for i, row in enumerate(cpu_rows):
        outcome: PickOutcome | None = gpu["outcomes"].get(i)
        if outcome is None:
            continue
        validity = outcome.validity
        records.append(
            {
                "robot": row["robot"], "arm": row["arm"], "object": row["object"],
                "seed": row["seed"],
                "cpu_success": bool(row["success"]), "gpu_success": outcome.success,
                "cpu_reason": row["failure_reason"], "gpu_reason": outcome.failure_reason,
                "cpu_valid": bool(row.get("valid")),
                "gpu_valid": bool(validity.valid) if validity else False,
                "cpu_invalid": row.get("invalid_reason", ""),
                "gpu_invalid": validity.invalid_reason if validity else "",
                "cpu_lift": row.get("lift_height_m"), "gpu_lift": outcome.lift_height_m,
                "cpu_robustness": row.get("robustness_g"),
                "gpu_robustness": validity.measure.robustness_g if validity else math.nan,
            }
        )  # fmt: skip
    return records


def measure(
    seeds: int,
    workers: int,
    device: str,
    arms: tuple[str, ...] = ARMS,
    objects: tuple[str, ...] = OBJECTS,
) -> dict[str, Any]:
    all_specs = specs(tasks(arms, objects), seeds)
    cpu_rows, cpu_s = run_cpu(all_specs, workers)
    gpu = run_gpu(all_specs, workers, device)
    records = agreement(cpu_rows, gpu)
    n = len(all_specs)
    return {"n": n, "cpu_s": cpu_s, "records": records, "gpu": gpu}


def figures(result: dict[str, Any]) -> list[Figure]:
    n, gpu, records = result["n"], result["gpu"], result["records"]
    cpu_rate = 3600.0 * n / result["cpu_s"]
    gpu_rate = 3600.0 * n / (gpu["plan_s"] + gpu["gpu_s"])
    same_ref = sum(
        r["cpu_success"] == r["gpu_success"] and r["cpu_reason"] == r["gpu_reason"] for r in records
    )
    same_valid = sum(r["cpu_valid"] == r["gpu_valid"] for r in records)
    k = max(1, len(records))
    what = f"{n} episodes ({len(records)} executed)"
    return [
        figure(SECTION, "episodes per hour, CPU only (mujoco)", [cpu_rate], "ep/h", notes=what),
        figure(
            SECTION, "episodes per hour, planning on CPU + physics on GPU (mjwarp)", [gpu_rate],
            "ep/h", target=TARGET_RATE, higher_is_better=True,
            notes=f"planning {gpu['plan_s']:.1f} s, device {gpu['gpu_s']:.1f} s in sequence",
        ),
        figure(
            SECTION, "ratio GPU path / CPU only", [gpu_rate / cpu_rate], "x",
            target=TARGET_RATIO, higher_is_better=True,
        ),
        figure(
            SECTION, "physics world-steps per second (mjwarp)",
            [gpu["world_steps"] / max(gpu["physics_s"] + gpu["tug_s"], 1e-9)], "steps/s",
            notes=f"largest batch {gpu['max_batch']} worlds",
        ),
        figure(
            SECTION, "tug rung-worlds (mjwarp)", [gpu["tug_rungs"]], "worlds",
            notes=f"in {gpu['tug_rounds']:.0f} rounds, {gpu['tug_s']:.1f} s on the device",
        ),
        figure(SECTION, "reference outcome agreement", [same_ref / k], "share"),
        figure(SECTION, "validity agreement", [same_valid / k], "share"),
    ]  # fmt: skip


def run(quick: bool) -> list[Figure]:
    from harness.engines.mjwarp_engine import default_device

    seeds = 2 if quick else 32
    workers = os.cpu_count() or 1
    return figures(measure(seeds, workers, default_device()))


def main() -> None:
    """``python -m harness.benchmarks.engines SEEDS OUT_DIR [ARMS...]``: the section's run with
    every record written (agreement.jsonl, summary.json)."""
    import sys

    from harness.engines.mjwarp_engine import default_device

    seeds, out = int(sys.argv[1]), Path(sys.argv[2])
    arms = tuple(sys.argv[3:]) or ARMS
    objects = tuple(os.environ.get("BENCH_OBJECTS", ",".join(OBJECTS)).split(","))
    out.mkdir(parents=True, exist_ok=True)
    result = measure(seeds, os.cpu_count() or 1, default_device(), arms, objects)
    with (out / "agreement.jsonl").open("w") as f:
        for record in result["records"]:
            f.write(json.dumps(record, default=float) + "\n")
    gpu = {k: v for k, v in result["gpu"].items() if k not in ("planned", "outcomes")}
    summary = {"n": result["n"], "cpu_s": result["cpu_s"], "gpu": gpu}
    (out / "summary.json").write_text(json.dumps(summary, indent=1))
    for fig in figures(result):
        print(f"{fig.name}: {fig.median:.4g} {fig.unit} {fig.notes or ''}", flush=True)
    print(json.dumps(summary), flush=True)


if __name__ == "__main__":
    main()
