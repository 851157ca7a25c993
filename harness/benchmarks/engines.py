"""Benchmark: the ``mjwarp`` engine against the ``mujoco`` engine, agreement and throughput.

The same episodes (the five arms of ``tasks/pick``, objects cube and banana, seeds 0..n-1) run
twice on this box: CPU-only (``mujoco``, one process per core, as ``harness sweep`` runs) and
with the physics on the GPU (``mjwarp``): the same worker processes plan each episode and make
its control schedule (``harness.engines.mjwarp.schedule``) and send the job (``DeviceJob``) to this
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
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

from harness.benchmarks.engines_batches import GpuDevices, batch_key
from harness.benchmarks.framework import Figure, figure
from harness.config import TaskConfig, apply_overrides, load_task
from harness.config.robot_registry import available_robots, canonical_task_files
from harness.objects.assets import repo_root
from harness.pick.outcome import PickOutcome
from harness.runs.expansion import point_overrides

SECTION = "engines"
# Every canonical task file (tasks/pick/<robot>[_arm].yaml) of every bundled robot.
ARMS = tuple(p.stem for robot in available_robots() for p in canonical_task_files(robot))
OBJECTS = ("cube", "banana")
TARGET_RATIO = 8.0
TARGET_RATE = 3_000_000.0


_SCENES: dict[Any, Any] = {}


def _plan(spec: Any) -> tuple[dict[str, Any], Any]:
    """Worker: plan one episode; its row (when it ended before execution) and its job
    (``harness.runs.warm.plan_job``, the path ``harness compile`` plans with)."""
    from harness.runs.warm import plan_job

    return plan_job(spec, _SCENES)


def _cpu(spec: Any) -> dict[str, Any]:
    """Worker: one whole episode on the mujoco engine (no viewer trace, as on the GPU path)."""
    from harness.episode import run_episode

    return run_episode(dataclasses.replace(spec, trace=False), _SCENES).row


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


def _plan_chunk(chunk: list[tuple[int, Any]]) -> tuple[list[tuple[int, Any, Any]], float]:
    """Worker: plan a chunk of (index, spec); each one's row and job, and when it finished
    (``time.time``, comparable across the box's processes)."""
    out = []
    for i, spec in chunk:
        row, job = _plan(spec)
        out.append((i, row, job))
    return out, time.time()


def run_gpu(
    all_specs: list[Any],
    workers: int,
    device: str,
    batch: int = 1024,
    chunk: int = 8,
    bucket: int = 1,
    min_batch: int = 0,
    lanes: int = 0,
) -> dict[str, Any]:
    """Plan on the pool while the device steps what is planned: as soon as ``bucket * batch``
    jobs of one task model wait, the ``batch`` shortest of them run as one batch of worlds (the
    pool keeps planning meanwhile); the rest run once planning is done, shortest first, in
    batches of ``batch``. ``bucket`` > 1 trades a later first batch for batches of similar
    schedule lengths (every world of a batch is stepped for its longest schedule).
    ``min_batch`` > 0 with ``bucket`` 1 feeds the device when it has a free slot instead: then
    the (up to) ``batch`` shortest of the jobs waiting run, once at least ``min_batch`` wait, so
    that the device starts early and the waiting pool a batch is sorted from grows while the
    device is the slower side. With ``bucket`` > 1 it only starts the device while nothing is on
    it (the first batch after ``min_batch`` jobs instead of ``bucket * batch``); the other
    batches are bucketed. ``lanes`` > 0 streams every planned job to ``lanes`` lanes of its
    task model instead (``harness.engines.mjwarp.stream``: no batches, no padding). The
    outcomes and where the time went."""
    gpu = GpuDevices(device)
    planned: list[Any] = [None] * len(all_specs)
    indexed = list(enumerate(all_specs))

    def steps_of(j: int) -> int:
        return planned[j][1].schedule.steps

    with _pool(workers) as pool:
        _warm(pool, all_specs, workers, gpu, lanes)
        start, wall_start = time.perf_counter(), time.time()
        futures = [
            pool.submit(_plan_chunk, indexed[k : k + chunk]) for k in range(0, len(indexed), chunk)
        ]
        waiting: dict[str, list[int]] = {}
        finished = 0.0
        for future in as_completed(futures):
            results, done_at = future.result()
            finished = max(finished, done_at)
            for i, row, job in results:
                planned[i] = (row, job)
                if job is None:
                    continue
                if lanes:
                    gpu.to_stream(i, job, lanes)
                    continue
                group = waiting.setdefault(batch_key(job), [])
                group.append(i)
                if _ready(gpu, len(group), batch, bucket, min_batch):
                    # the `batch` shortest schedules of what waits: a lockstep batch is
                    # stepped for its longest schedule
                    group.sort(key=steps_of)
                    gpu.step(group[:batch], [planned[j][1] for j in group[:batch]])
                    del group[:batch]
        plan_s = finished - wall_start
    gpu.close_streams()
    for group in waiting.values():
        group.sort(key=steps_of)
        for k in range(0, len(group), batch):
            part = group[k : k + batch]
            gpu.step(part, [planned[j][1] for j in part])
    gpu.drain()
    total_s = time.perf_counter() - start
    return {
        "planned": planned, "outcomes": gpu.outcomes, "plan_s": plan_s,
        "device_s": gpu.device_s, "total_s": total_s, "compile_s": gpu.compile_s,
        "workers": workers, "batch": batch, "bucket": bucket, "min_batch": min_batch,
        "lanes": lanes,
        "slots": gpu.slot_count,
        **gpu.counts, **gpu.totals,
        **gpu.peaks, "buffers": os.environ.get("BENCH_BUFFERS", "default"),
        "retire": os.environ.get("BENCH_RETIRE", "default"),
    }  # fmt: skip


def _warm(pool: ProcessPoolExecutor, all_specs: list[Any], workers: int, gpu: GpuDevices,
          lanes: int) -> None:  # fmt: skip
    """Start the workers and build their scenes (one episode of each task among them), and
    load the device's kernels for each task model, off the clock."""
    firsts = {spec.task.model_dump_json(): spec for spec in reversed(all_specs)}
    warm = list(pool.map(_plan, (list(firsts.values()) + all_specs)[: max(workers, len(firsts))]))
    gpu.load([job for _, job in warm])
    if lanes:
        for job in {batch_key(j): j for _, j in warm if j is not None}.values():
            gpu.warm_lanes(job)


def _ready(gpu: GpuDevices, waiting: int, batch: int, bucket: int, min_batch: int) -> bool:
    """Whether a batch runs now from ``waiting`` planned jobs of one task model: ``bucket *
    batch`` wait; or, with ``min_batch``, ``min_batch`` wait and the device has nothing to do
    (``bucket`` > 1: a *warm start*, so that the device does not idle while the first buckets
    fill) or, with ``bucket`` 1, a slot is free (feeding)."""
    if min_batch > 0 and waiting >= min_batch:
        if gpu.in_flight() == 0:
            return True
        if bucket == 1:
            return gpu.in_flight() < gpu.slot_count
    return waiting >= bucket * batch


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
    # BENCH_CPU_EPISODES=k: the CPU-only rate from the first k episodes (a large GPU batch
    # would otherwise spend most of the call on the CPU-only run; its rate does not depend on
    # the count)
    cpu_n = min(len(all_specs), int(os.environ.get("BENCH_CPU_EPISODES", "0")) or len(all_specs))
    cpu_rows, cpu_s = run_cpu(all_specs[:cpu_n], workers)
    # one core less for planning on the GPU path: this process drives the device
    # (BENCH_PLANNERS=k: k planning processes instead)
    planners = int(os.environ.get("BENCH_PLANNERS", "0")) or max(1, workers - 1)
    batch = int(os.environ.get("BENCH_BATCH", "1024"))
    bucket = int(os.environ.get("BENCH_BUCKET", "1"))
    # BENCH_MIN_BATCH=k: feed the device when a slot is free, from k waiting jobs up
    min_batch = int(os.environ.get("BENCH_MIN_BATCH", "0"))
    # BENCH_LANES=k: stream the jobs through k lanes per task model instead of batches
    lanes = int(os.environ.get("BENCH_LANES", "0"))
    gpu = run_gpu(
        all_specs, planners, device, batch, bucket=bucket, min_batch=min_batch, lanes=lanes
    )
    records = agreement(cpu_rows, gpu)
    n = len(all_specs)
    return {"n": n, "cpu_n": cpu_n, "cpu_s": cpu_s, "records": records, "gpu": gpu}


def figures(result: dict[str, Any]) -> list[Figure]:
    n, gpu, records = result["n"], result["gpu"], result["records"]
    cpu_rate = 3600.0 * result.get("cpu_n", n) / result["cpu_s"]
    gpu_rate = 3600.0 * n / gpu["total_s"]
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
            notes=(
                f"{gpu['total_s']:.1f} s end to end: planning {gpu['plan_s']:.1f} s on "
                f"{gpu['workers']} processes overlapped with {_device_work(gpu)} "
                f"({gpu['device_s']:.1f} s)"
            ),
        ),
        figure(
            SECTION, "ratio GPU path / CPU only", [gpu_rate / cpu_rate], "x",
            target=TARGET_RATIO, higher_is_better=True,
        ),
        figure(
            SECTION, "physics world-steps per second (mjwarp)",
            [gpu["world_steps"] / max(gpu["physics_s"] + gpu["tug_s"], 1e-9)], "steps/s",
            notes=(
                f"largest batch {gpu['max_batch']} worlds; buffers {gpu.get('buffers')}: peak "
                f"{gpu.get('peak_rows', 0):.0f} constraint rows in a world, "
                f"{gpu.get('peak_contacts', 0):.1f} contacts per world, "
                f"{gpu.get('reruns', 0):.0f} worlds run again with the large buffers; "
                f"device memory high {gpu.get('memory_high_gb', 0):.1f} GB; "
                f"{'idle lanes' if gpu.get('lanes') else 'padding'} "
                f"{1 - gpu.get('span_steps', 0) / max(1, gpu.get('motion_steps', 0)):.1%} of "
                f"the motion's {gpu.get('motion_steps', 0):.3g} world-steps"
            ),
        ),
        figure(
            SECTION, "tug rung-worlds (mjwarp)", [gpu["tug_rungs"]], "worlds",
            notes=f"in {gpu['tug_rounds']:.0f} rounds, {gpu['tug_s']:.1f} s on the device",
        ),
        figure(SECTION, "reference outcome agreement", [same_ref / k], "share"),
        figure(SECTION, "validity agreement", [same_valid / k], "share"),
    ]  # fmt: skip


def _device_work(gpu: dict[str, Any]) -> str:
    if gpu.get("lanes"):
        return f"{gpu['batches']} lane stream(s) of {gpu['lanes']} lanes"
    return f"{gpu['batches']} device batches of <= {gpu['batch']} worlds"


def run(quick: bool) -> list[Figure]:
    from harness.engines.mjwarp.engine import default_devices

    seeds = 2 if quick else 32
    workers = os.cpu_count() or 1
    return figures(measure(seeds, workers, ",".join(default_devices())))


def main() -> None:
    """``python -m harness.benchmarks.engines SEEDS OUT_DIR [ARMS...]``: the section's run with
    every record written (agreement.jsonl, summary.json)."""
    import sys

    from harness.engines.mjwarp.engine import default_devices

    seeds, out = int(sys.argv[1]), Path(sys.argv[2])
    arms = tuple(sys.argv[3:]) or ARMS
    objects = tuple(os.environ.get("BENCH_OBJECTS", ",".join(OBJECTS)).split(","))
    out.mkdir(parents=True, exist_ok=True)
    devices = ",".join(default_devices())
    result = measure(seeds, os.cpu_count() or 1, devices, arms, objects)
    with (out / "agreement.jsonl").open("w") as f:
        for record in result["records"]:
            f.write(json.dumps(record, default=float) + "\n")
    gpu = {k: v for k, v in result["gpu"].items() if k not in ("planned", "outcomes")}
    summary = {"n": result["n"], "cpu_n": result["cpu_n"], "cpu_s": result["cpu_s"], "gpu": gpu}
    (out / "summary.json").write_text(json.dumps(summary, indent=1))
    for fig in figures(result):
        print(f"{fig.name}: {fig.median:.4g} {fig.unit} {fig.notes or ''}", flush=True)
    print(json.dumps(summary), flush=True)


if __name__ == "__main__":
    main()
