"""Sweeps: expand a sweep YAML into episodes and run them on a serial, process-pool or Ray executor.

A sweep is tasks x points x seeds. Points come from a grid (cartesian product of ``axes``) or from
``points`` random draws over ``random_axes``; each axis is a dotted task key such as
``pick.approach_filter`` or ``object.friction``. Robot-neutral keys (``approach_filter``,
``facing_filter``) let one sweep span robots with different end-effector conventions.

Determinism: the episode seed depends only on (sweep seed, episode index), so episode k of every
point sees the same object placement and home noise -- points are compared on common random
numbers. Episode ids hash (task, point, episode index), so resuming runs exactly what is missing.

Robustness: results stream to the append-only store as episodes finish; a worker that dies (even
by a segfault) turns its episode into an ``error`` row and is replaced; Ctrl-C keeps what finished.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import multiprocessing as mp
import os
import signal
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from harness.config.models import (
    ConfigError,
    SweepConfig,
    TaskConfig,
    apply_overrides,
    load_sweep,
    load_task,
    validate_model,
)

# --------------------------------------------------------------------------------------------
# Expansion


@dataclass(frozen=True)
class SweepEpisode:
    """One episode of a sweep: the task with the point's overrides applied, and its identity."""

    episode_id: str
    task: TaskConfig
    task_name: str
    point_id: int
    point: dict[str, Any]
    episode_index: int
    seed: int
    run: str
    record: bool = False


def episode_seed(sweep_seed: int, episode_index: int) -> int:
    """Seed of episode ``episode_index``; independent of task and point (common random numbers)."""
    sequence = np.random.SeedSequence([int(sweep_seed), int(episode_index)])
    return int(sequence.generate_state(1, dtype=np.uint64)[0] & ((1 << 63) - 1))


def episode_id(task_name: str, point: dict[str, Any], episode_index: int) -> str:
    """Deterministic id from the task, the point's parameter values and the episode index."""
    key = json.dumps([task_name, point, episode_index], sort_keys=True, default=str)
    digest = hashlib.sha1(key.encode()).hexdigest()[:10]
    return f"{task_name}-e{episode_index:04d}-{digest}"


def absolute_paths(task: TaskConfig) -> TaskConfig:
    """Make object mesh / grasp paths absolute so the task no longer depends on its file."""
    base = task.base_dir()
    objects = []
    for obj in task.objects:
        update: dict[str, Any] = {}
        for key in ("mesh", "grasps"):
            value = getattr(obj, key)
            if value and not Path(value).is_absolute() and (base / value).exists():
                update[key] = str((base / value).resolve())
        objects.append(obj.model_copy(update=update) if update else obj)
    return task.model_copy(update={"objects": objects})


INTERNDATA_ENTRY_KEYS = ("interndata", "asset_root", "objects")


def load_sweep_tasks(
    sweep: SweepConfig, sweep_path: Path | None, notes: list[str] | None = None
) -> list[TaskConfig]:
    """Resolve the sweep's task entries (paths, inline tasks, InternDataEngine files).

    What each InternDataEngine file contributes and skips (other skills, ignored keys,
    approximations) is appended to ``notes`` when given.
    """
    base = sweep_path.resolve().parent if sweep_path else Path.cwd()
    tasks: list[TaskConfig] = []
    for index, entry in enumerate(sweep.tasks):
        if isinstance(entry, str):
            path = Path(entry) if Path(entry).is_absolute() else base / entry
            try:
                tasks.append(absolute_paths(load_task(path)))
            except ConfigError as exc:
                if exc.file is None or "file not found" in exc.message:
                    raise ConfigError(
                        f"task file {str(path)!r}: {exc.message}",
                        file=sweep_path,
                        key=f"tasks[{index}]",
                    ) from None
                raise
        elif "interndata" in entry:
            from harness.config.interndata.mapper import load_interndata_tasks, note_lines

            unknown = [k for k in entry if k not in INTERNDATA_ENTRY_KEYS]
            if unknown:
                raise ConfigError(
                    f"unknown key {unknown[0]!r} in an interndata entry; expected "
                    f"{', '.join(INTERNDATA_ENTRY_KEYS)}",
                    file=sweep_path,
                    key=f"tasks[{index}].{unknown[0]}",
                )
            path = Path(entry["interndata"])
            path = path if path.is_absolute() else base / path
            root = entry.get("asset_root")
            objects = {k: str(base / v) for k, v in (entry.get("objects") or {}).items()}
            picks = load_interndata_tasks(
                path, asset_root=base / root if root else None, objects=objects, check_grasps=True
            )
            if notes is not None:
                notes.extend(note_lines(path, picks))
            tasks.extend(absolute_paths(pick.task) for pick in picks)
        else:
            data = {"source": str(sweep_path) if sweep_path else None, **entry}
            task = validate_model(TaskConfig, data, None, ("tasks", index))
            tasks.append(absolute_paths(task))
    names = [task.name for task in tasks]
    duplicates = sorted({name for name in names if names.count(name) > 1})
    if duplicates:
        raise ConfigError(
            f"task names must be unique within a sweep, repeated: {duplicates}",
            file=sweep_path,
            key="tasks",
        )
    return tasks


def sweep_points(sweep: SweepConfig) -> list[dict[str, Any]]:
    """The parameter points: grid product in axis order, or seeded random draws."""
    if sweep.mode == "grid":
        keys = list(sweep.axes)
        if not keys:
            return [{}]
        return [
            dict(zip(keys, values, strict=True))
            for values in itertools.product(*(sweep.axes[k] for k in keys))
        ]
    rng = np.random.default_rng(np.random.SeedSequence([sweep.seed, 0x5EED]))
    points = []
    for _ in range(sweep.points):
        point: dict[str, Any] = {}
        for key, axis in sweep.random_axes.items():
            if axis.choices is not None:
                point[key] = axis.choices[int(rng.integers(len(axis.choices)))]
            else:
                point[key] = float(rng.uniform(axis.low, axis.high))
        points.append(point)
    return points


FILTER_KEYS = {"x": "filter_x_dir", "y": "filter_y_dir", "z": "filter_z_dir"}


def filter_overrides(task: TaskConfig, point: dict[str, Any]) -> dict[str, Any]:
    """A point's overrides, plus clearing whatever filter it replaces on the same EE axis.

    A sweep axis over ``pick.approach_filter`` must replace the task's own filter on that
    robot's approach axis (``filter_z_dir`` on fr3, ``filter_x_dir`` on lift2, ...), and an
    axis over ``pick.filter_z_dir`` replaces a neutral filter that lands on z. Without this, a
    robot-neutral sweep over reference-form task files would set the same axis twice.
    """
    neutral = {"pick.approach_filter": "approach_filter", "pick.facing_filter": "facing_filter"}
    swept = [
        key for key in point if key in neutral or key.removeprefix("pick.") in FILTER_KEYS.values()
    ]
    if not swept:
        return point
    from harness.robots.model import RobotModel

    convention = RobotModel.load(task.robot).convention
    axis_of = {"approach_filter": convention.approach_axis, "facing_filter": convention.facing_axis}
    cleared: dict[str, Any] = {}
    for key in swept:
        if key in neutral:
            cleared[f"pick.{FILTER_KEYS[axis_of[neutral[key]]]}"] = None
        else:
            axis = key.removeprefix("pick.")[len("filter_")]
            for name, neutral_axis in axis_of.items():
                if neutral_axis == axis:
                    cleared[f"pick.{name}"] = None
    cleared = {k: v for k, v in cleared.items() if k not in point}
    return {**cleared, **point}


def object_overrides(task: TaskConfig, point: dict[str, Any]) -> dict[str, Any]:
    """Swapping the target object's mesh also renames the object after the mesh.

    A sweep axis ``object.mesh: [cube, banana]`` then reports ``object = banana`` in its rows
    (and ``pick.objects`` follows), unless the point names the object itself.
    """
    mesh_keys = ("object.mesh", "objects.0.mesh")
    mesh = next((point[k] for k in mesh_keys if k in point), None)
    if mesh is None or any(k in point for k in ("object.name", "objects.0.name")):
        return {}
    target = task.target_object
    if task.objects[0].name != target.name:
        return {}
    name = Path(str(mesh)).stem if Path(str(mesh)).suffix else str(mesh)
    if name == target.name:
        return {}
    if name in {obj.name for obj in task.objects}:
        raise ConfigError(f"object mesh {mesh!r} would rename the target to an existing name")
    picked = [name if n == target.name else n for n in (task.pick.objects or [target.name])]
    return {"objects.0.name": name, "pick.objects": picked}


def point_overrides(task: TaskConfig, point: dict[str, Any]) -> dict[str, Any]:
    """Everything a point changes in a task: its own keys plus the implied ones."""
    implied = {**filter_overrides(task, point), **object_overrides(task, point)}
    return {**implied, **point}


def check_filters(task: TaskConfig) -> None:
    """Resolve the task's filters for its robot now, so clashes fail at expansion."""
    from harness.grasps import resolve_filters
    from harness.robots.model import RobotModel

    try:
        resolve_filters(task.pick, RobotModel.load(task.robot).convention)
    except ConfigError as exc:
        raise ConfigError(exc.message, key=f"pick.{exc.key}" if exc.key else "pick") from None


def select_samples(episodes: list[SweepEpisode], count: int) -> set[str]:
    """A deterministic sample of ``count`` episode ids (lowest id hashes)."""
    ranked = sorted(episodes, key=lambda e: hashlib.sha1(e.episode_id.encode()).hexdigest())
    return {e.episode_id for e in ranked[:count]}


def expand(
    sweep: SweepConfig, sweep_path: Path | None, tasks: list[TaskConfig] | None = None
) -> list[SweepEpisode]:
    """All episodes of the sweep, in a deterministic order (task, point, episode).

    ``tasks`` are the sweep's resolved tasks when the caller has already loaded them.
    """
    if tasks is None:
        tasks = load_sweep_tasks(sweep, sweep_path)
    points = sweep_points(sweep)
    episodes: list[SweepEpisode] = []
    for task in tasks:
        for point_id, point in enumerate(points):
            try:
                configured = apply_overrides(task, point_overrides(task, point))
                check_filters(configured)
            except ConfigError as exc:
                raise ConfigError(
                    f"point {point_id} {point} does not apply to task {task.name!r}: {exc.message}",
                    file=sweep_path,
                    key=f"axes.{exc.key}" if exc.key else "axes",
                ) from None
            for index in range(sweep.episodes_per_point):
                eid = episode_id(task.name, point, index)
                episodes.append(
                    SweepEpisode(
                        episode_id=eid,
                        task=configured,
                        task_name=task.name,
                        point_id=point_id,
                        point=point,
                        episode_index=index,
                        seed=episode_seed(sweep.seed, index),
                        run=sweep.name,
                    )
                )
    if sweep.record.startswith("sample:"):
        chosen = select_samples(episodes, int(sweep.record.split(":")[1]))
        episodes = [
            SweepEpisode(**{**e.__dict__, "record": e.episode_id in chosen}) for e in episodes
        ]
    elif sweep.record == "all":
        episodes = [SweepEpisode(**{**e.__dict__, "record": True}) for e in episodes]
    return episodes


# --------------------------------------------------------------------------------------------
# Running one episode (in whichever process)

_SCENE_CACHE: dict[Any, Any] = {}


def execute(episode: SweepEpisode, run_dir: str, record_policy: str) -> dict[str, Any]:
    """Run one episode and return its flat row; writes its recording when chosen.

    Never raises for episode-level problems: ``run_episode`` turns them into failure reasons,
    and anything that escapes it becomes an ``error`` row here.
    """
    from harness.episode import EpisodeSpec, run_episode

    start = time.perf_counter()
    _inject_fault(episode.episode_id)
    try:
        spec = EpisodeSpec(
            task=episode.task,
            seed=episode.seed,
            episode_index=episode.episode_index,
            point_id=episode.point_id,
            point=episode.point,
            run=episode.run,
            record=episode.record,
            episode_id=episode.episode_id,
        )
        result = run_episode(spec, scene_cache=_SCENE_CACHE)
        row = dict(result.row)
    except Exception as exc:  # the last line of defence; run_episode already catches
        result = None
        row = error_row(episode, f"{type(exc).__name__}: {exc}")
    row.update(_identity(episode))
    row.setdefault("wall_time_s", time.perf_counter() - start)
    row["worker_peak_rss_mb"] = _peak_rss_mb()
    failed = not bool(row.get("success"))
    wants = episode.record or (record_policy == "failures" and failed)
    if wants and result is not None and getattr(result, "trace", None) is not None:
        try:
            from harness.viz.recording import record_episode

            path = Path(run_dir) / "episodes" / f"{episode.episode_id}.rrd"
            record_episode(result, path, episode.task)
            row["recording"] = str(path.relative_to(run_dir))
        except Exception as exc:  # a recording problem must not lose the episode
            row["recording_error"] = f"{type(exc).__name__}: {exc}"
    return row


FAULT_ENV = "PICK_HARNESS_INJECT_SEGFAULT"


def _inject_fault(episode_id_: str) -> None:
    """Fault injection for tests of crash recovery: a real segfault in the worker process.

    Only when ``PICK_HARNESS_INJECT_SEGFAULT`` names this episode id (comma-separated list).
    """
    targets = os.environ.get(FAULT_ENV, "")
    if targets and episode_id_ in targets.split(","):
        import ctypes

        ctypes.string_at(0)  # dereference NULL: SIGSEGV, as a crashing C extension would


def _peak_rss_mb() -> float:
    """Peak resident memory of this process in MiB.

    Linux: ``VmHWM`` -- a spawned worker's ``ru_maxrss`` carries the parent's RSS across
    fork + exec and over-reports. Elsewhere ``ru_maxrss`` (KiB on Linux, bytes on macOS).
    """
    try:
        with open("/proc/self/status", encoding="ascii") as handle:
            for line in handle:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    import resource
    import sys

    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / (1024 * 1024) if sys.platform == "darwin" else peak / 1024


def _identity(episode: SweepEpisode) -> dict[str, Any]:
    row: dict[str, Any] = {
        "episode_id": episode.episode_id,
        "run": episode.run,
        "task": episode.task_name,
        "point_id": episode.point_id,
        "point": json.dumps(episode.point, sort_keys=True, default=str),
        "episode_index": episode.episode_index,
        "seed": episode.seed,
    }
    for key, value in episode.point.items():
        row[f"param.{key}"] = (
            value if isinstance(value, (int, float, str, bool)) else json.dumps(value)
        )
    return row


def error_row(episode: SweepEpisode, message: str) -> dict[str, Any]:
    """The row of an episode that could not produce its own (crash, lost worker)."""
    task = episode.task
    row = {
        "robot": task.robot,
        "arm": task.arm,
        "object": task.target_object.name,
        "semantics": task.pick.semantics,
        "test_mode": task.pick.test_mode,
        "timing": task.pick.timing,
        "success": False,
        "failure_reason": "error",
        "error_message": message,
    }
    row.update(_identity(episode))
    return row


# --------------------------------------------------------------------------------------------
# Executors

OnResult = Callable[[dict[str, Any]], None]


@dataclass
class RunStats:
    finished: int = 0
    crashed: int = 0
    interrupted: bool = False
    wall_time_s: float = 0.0
    errors: list[str] = field(default_factory=list)


def run_serial(
    episodes: list[SweepEpisode], run_dir: Path, record: str, on_result: OnResult
) -> RunStats:
    stats = RunStats()
    start = time.perf_counter()
    try:
        for episode in episodes:
            on_result(execute(episode, str(run_dir), record))
            stats.finished += 1
    except KeyboardInterrupt:
        stats.interrupted = True
    stats.wall_time_s = time.perf_counter() - start
    return stats


def _worker_main(conn: Connection, run_dir: str, record: str) -> None:
    """Process-pool worker: receive episodes on ``conn``, send rows back; scenes stay cached."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    while True:
        try:
            episode = conn.recv()
        except EOFError:
            return
        if episode is None:
            return
        conn.send(execute(episode, run_dir, record))


@dataclass
class _Worker:
    process: Any
    conn: Connection
    episode: SweepEpisode | None = None


def run_process_pool(
    episodes: list[SweepEpisode],
    run_dir: Path,
    record: str,
    on_result: OnResult,
    workers: int,
) -> RunStats:
    """One process per worker, one episode in flight per worker; dead workers are replaced."""
    context = mp.get_context("spawn")
    stats = RunStats()
    start = time.perf_counter()
    pending: Iterator[SweepEpisode] = iter(episodes)
    pool: list[_Worker] = []

    def spawn() -> _Worker:
        parent, child = context.Pipe()
        process = context.Process(
            target=_worker_main, args=(child, str(run_dir), record), daemon=True
        )
        # Ctrl-C goes to the whole terminal process group. The worker ignores SIGINT once its
        # main runs, but a signal during its start-up (imports) would kill it and look like a
        # crash. The child inherits the signal mask across fork + exec, so start it with SIGINT
        # blocked: only the parent ever sees Ctrl-C, and it stops the workers itself.
        blocked = hasattr(signal, "pthread_sigmask")
        if blocked:
            signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            process.start()
        finally:
            if blocked:
                signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
        child.close()
        return _Worker(process, parent)

    def assign(worker: _Worker) -> bool:
        episode = next(pending, None)
        worker.episode = episode
        if episode is None:
            return False
        worker.conn.send(episode)
        return True

    try:
        for _ in range(max(1, min(workers, len(episodes)))):
            worker = spawn()
            pool.append(worker)
            assign(worker)
        while any(w.episode is not None for w in pool):
            busy = [w for w in pool if w.episode is not None]
            ready = wait([w.conn for w in busy] + [w.process.sentinel for w in busy])
            for worker in busy:
                if worker.conn in ready:
                    try:
                        row = worker.conn.recv()
                    except (EOFError, OSError):
                        row = None
                    if row is not None:
                        on_result(row)
                        stats.finished += 1
                        assign(worker)
                        continue
                if worker.process.sentinel in ready or not worker.process.is_alive():
                    worker.process.join(timeout=1)
                    code = worker.process.exitcode
                    reason = (
                        f"worker crashed (signal {-code})"
                        if code and code < 0
                        else f"worker exited with code {code}"
                    )
                    assert worker.episode is not None
                    on_result(error_row(worker.episode, reason))
                    stats.finished += 1
                    stats.crashed += 1
                    pool.remove(worker)
                    replacement = spawn()
                    pool.append(replacement)
                    assign(replacement)
    except KeyboardInterrupt:
        stats.interrupted = True
    finally:
        for worker in pool:
            try:
                if stats.interrupted:
                    worker.process.terminate()
                else:
                    worker.conn.send(None)
            except (OSError, BrokenPipeError):
                pass
        for worker in pool:
            worker.process.join(timeout=5)
            if worker.process.is_alive():
                worker.process.kill()
    stats.wall_time_s = time.perf_counter() - start
    return stats


def run_ray(
    episodes: list[SweepEpisode],
    run_dir: Path,
    record: str,
    on_result: OnResult,
    workers: int,
    address: str | None = None,
) -> RunStats:
    """Ray actors (one scene cache each); a dead actor's episode becomes an error row."""
    try:
        import ray
    except ImportError as exc:  # pragma: no cover - depends on the extra
        from harness.errors import HarnessError

        raise HarnessError(
            "the ray backend needs the 'ray' extra: pip install 'pick-harness[ray]'"
        ) from exc

    started_here = not ray.is_initialized()
    if started_here:
        if address:
            ray.init(address=address, log_to_driver=False)
        else:
            ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)

    @ray.remote(num_cpus=1, max_restarts=-1)
    class EpisodeActor:
        def run(self, episode: SweepEpisode) -> dict[str, Any]:
            return execute(episode, str(run_dir), record)

    stats = RunStats()
    start = time.perf_counter()
    pending = iter(episodes)
    actors = [EpisodeActor.remote() for _ in range(max(1, min(workers, len(episodes))))]
    in_flight: dict[Any, tuple[Any, SweepEpisode]] = {}

    def submit(actor: Any) -> None:
        episode = next(pending, None)
        if episode is not None:
            in_flight[actor.run.remote(episode)] = (actor, episode)

    try:
        for actor in actors:
            submit(actor)
        while in_flight:
            done, _ = ray.wait(list(in_flight), num_returns=1)
            ref = done[0]
            actor, episode = in_flight.pop(ref)
            try:
                row = ray.get(ref)
            except Exception as exc:  # actor died (segfault) or task error
                row = error_row(episode, f"ray worker failed: {type(exc).__name__}")
                stats.crashed += 1
            on_result(row)
            stats.finished += 1
            submit(actor)
    except KeyboardInterrupt:
        stats.interrupted = True
        for ref in in_flight:
            ray.cancel(ref, force=True)
    finally:
        if started_here:
            ray.shutdown()
    stats.wall_time_s = time.perf_counter() - start
    return stats


# --------------------------------------------------------------------------------------------
# A whole sweep


@dataclass
class SweepOutcome:
    run_dir: Path
    total: int
    skipped_existing: int
    stats: RunStats


def default_workers() -> int:
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1)


def resolved_sweep_document(sweep: SweepConfig, tasks: list[TaskConfig]) -> dict[str, Any]:
    """The sweep as run: its settings with every task inlined (self-contained for --resume)."""
    data = sweep.model_dump(mode="json")
    data["tasks"] = [
        task.model_dump(mode="json", exclude={"source"}, exclude_none=True) for task in tasks
    ]
    return data


def prepare_run(
    sweep_path: Path | None, resume_dir: Path | None, out: Path | None
) -> tuple[SweepConfig, Path | None, Path]:
    """Load the sweep (from the run dir when resuming) and choose the run directory."""
    if resume_dir is not None:
        stored = resume_dir / "sweep.yaml"
        if not stored.is_file():
            raise ConfigError("not a run directory (no sweep.yaml)", file=resume_dir)
        return load_sweep(stored), stored, resume_dir
    if sweep_path is None:
        raise ConfigError("give a sweep YAML or --resume RUN_DIR")
    sweep = load_sweep(sweep_path)
    run_dir = out or Path("reports") / f"{sweep.name}-{time.strftime('%Y%m%d-%H%M%S')}"
    return sweep, sweep_path, run_dir


def write_sweep_yaml(run_dir: Path, sweep: SweepConfig, tasks: list[TaskConfig]) -> None:
    run_dir.mkdir(parents=True, exist_ok=True)
    text = yaml.safe_dump(resolved_sweep_document(sweep, tasks), sort_keys=False)
    (run_dir / "sweep.yaml").write_text(text, encoding="utf-8")


def run_sweep(
    sweep_path: Path | None = None,
    *,
    resume_dir: Path | None = None,
    out: Path | None = None,
    backend: str = "process",
    workers: int | None = None,
    address: str | None = None,
    record: str | None = None,
    episodes_per_point: int | None = None,
    progress: bool = True,
    limit: int | None = None,
) -> SweepOutcome:
    """Expand, run what is missing, store every row, then export, report and record.

    ``limit`` stops after that many new episodes (used to test interruption and resume).
    """
    from harness.runs.store import ResultStore

    sweep, source, run_dir = prepare_run(sweep_path, resume_dir, out)
    updates: dict[str, Any] = {}
    if record is not None:
        updates["record"] = record
    if episodes_per_point is not None:
        updates["episodes_per_point"] = episodes_per_point
    if updates:
        sweep = SweepConfig.model_validate({**sweep.model_dump(), **updates})
    notes: list[str] = []
    tasks = load_sweep_tasks(sweep, source, notes)
    episodes = expand(sweep, source, tasks)
    if resume_dir is None:
        if (run_dir / "sweep.yaml").exists():
            raise ConfigError(
                "run directory already holds a sweep; use --resume to continue it", file=run_dir
            )
        write_sweep_yaml(run_dir, sweep, tasks)
        if notes:
            from harness.config.interndata.mapper import write_notes

            write_notes(run_dir, notes)
    store = ResultStore(run_dir)
    done_ids = store.completed_ids()
    todo = [e for e in episodes if e.episode_id not in done_ids]
    if limit is not None:
        todo = todo[:limit]
    workers = workers or sweep.workers or default_workers()

    with _Progress(len(episodes), len(episodes) - len(todo), enabled=progress) as on_row:

        def on_result(row: dict[str, Any]) -> None:
            store.append(row)
            on_row(row)

        if backend == "serial":
            stats = run_serial(todo, run_dir, sweep.record, on_result)
        elif backend == "ray":
            stats = run_ray(todo, run_dir, sweep.record, on_result, workers, address)
        elif backend == "process":
            stats = run_process_pool(todo, run_dir, sweep.record, on_result, workers)
        else:
            raise ConfigError(f"unknown backend {backend!r}; use serial, process or ray")

    finalize_run(run_dir)
    return SweepOutcome(run_dir, len(episodes), len(episodes) - len(todo), stats)


def finalize_run(run_dir: Path) -> None:
    """Export the store, rebuild the report and the sweep overview recording."""
    from harness.report import build_report
    from harness.runs.store import ResultStore

    store = ResultStore(run_dir)
    store.export()
    build_report(run_dir)
    try:
        from harness.viz.sweep_recording import record_sweep

        record_sweep(run_dir)
    except ImportError:
        pass


class _Progress:
    """Rich progress bar with episodes per second, time left and the running success rate."""

    def __init__(self, total: int, already: int, enabled: bool) -> None:
        self.total = total
        self.already = already
        self.enabled = enabled
        self.successes = 0
        self.finished = 0

    def __enter__(self) -> Callable[[dict[str, Any]], None]:
        if not self.enabled:
            return self._count
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        self.bar = Progress(
            TextColumn("[bold]sweep"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("{task.fields[rate]:.2f} ep/s"),
            TextColumn("success {task.fields[success]}"),
            TimeElapsedColumn(),
            TextColumn("left"),
            TimeRemainingColumn(),
        )
        self.bar.start()
        self.task_id = self.bar.add_task(
            "sweep", total=self.total, completed=self.already, rate=0.0, success="-"
        )
        self.start = time.perf_counter()
        return self._advance

    def _count(self, row: dict[str, Any]) -> None:
        self.finished += 1
        self.successes += bool(row.get("success"))

    def _advance(self, row: dict[str, Any]) -> None:
        self._count(row)
        elapsed = max(time.perf_counter() - self.start, 1e-9)
        self.bar.update(
            self.task_id,
            advance=1,
            rate=self.finished / elapsed,
            success=f"{self.successes}/{self.finished}",
        )

    def __exit__(self, *exc: object) -> None:
        if self.enabled:
            self.bar.stop()
