"""The execution engine of a run, checked before anything is written, and kept on ``--resume``.

``--engine mjwarp`` needs the ``gpu`` extra (``warp`` and ``mujoco_warp`` importable) and a
device. Without them every episode used to become an ``error`` row (``harness run``), or a
sweep stopped after creating its run directory, whose ``--resume`` then ran on the CPU engine.
``check_engine`` is the one-line refusal ``run``, ``sweep`` and ``tune`` make at start;
``ENGINE_FILE`` records the engine in the run directory so that ``--resume`` keeps it
(``resume_engine``). Only imports and device counts are looked at here: the engine itself
(``harness.engines``) is not loaded.
"""

from __future__ import annotations

import importlib
import importlib.util
import os
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from harness.errors import HarnessError

ENGINE_FILE = "engine.txt"  # one line: the engine every episode of the run executes on
DEFAULT_ENGINE = "mujoco"
DEVICE_ENV = "HARNESS_WARP_DEVICE"  # harness.engines.mjwarp_engine reads the same variable
GPU_MODULES = ("warp", "mujoco_warp")
GPU_EXTRA_HINT = "pip install 'pick-harness[gpu]' (warp-lang, mujoco-warp)"


def missing_gpu_modules(
    find: Callable[[str], object | None] = importlib.util.find_spec,
) -> list[str]:
    """The modules of the ``gpu`` extra that cannot be imported here."""
    missing = []
    for name in GPU_MODULES:
        try:
            found = find(name)
        except (ImportError, ValueError):
            found = None
        if found is None:
            missing.append(name)
    return missing


def device_problem(requested: str | None, cuda_count: int) -> str | None:
    """Why the Warp device(s) ``requested`` (``HARNESS_WARP_DEVICE``: ``cpu``, ``cuda:1``, a
    comma-separated list, or unset: the CUDA devices) cannot run on a machine with
    ``cuda_count`` CUDA devices; None when they can."""
    names = [name.strip() for name in (requested or "").split(",") if name.strip()]
    if not names:
        if cuda_count > 0:
            return None
        return (
            "--engine mjwarp: Warp sees no CUDA device here; use --engine mujoco (the CPU "
            f"engine), or set {DEVICE_ENV}=cpu to run MuJoCo Warp on the CPU (slow; for tests)"
        )
    for name in names:
        if name == "cpu":
            continue
        index = name.removeprefix("cuda").removeprefix(":")
        if not name.startswith("cuda") or not (index == "" or index.isdigit()):
            return f"{DEVICE_ENV}={requested}: {name!r} is not a Warp device (cpu, cuda, cuda:N)"
        if int(index or 0) >= cuda_count:
            return (
                f"{DEVICE_ENV}={requested}: no device {name} here (Warp sees {cuda_count} CUDA "
                "device(s))"
            )
    return None


def _cuda_count() -> int:
    warp: Any = importlib.import_module("warp")  # importable: missing_gpu_modules() is []

    warp.config.quiet = True
    warp.init()
    return int(warp.get_cuda_device_count())


def check_engine(engine: str, cuda_count: Callable[[], int] = _cuda_count) -> None:
    """Raise one ``HarnessError`` line when ``engine`` cannot run here (the ``gpu`` extra or a
    device missing); the CPU engine always can."""
    if engine == DEFAULT_ENGINE:
        return
    if engine != "mjwarp":
        raise HarnessError(f"unknown engine {engine!r}: choose mujoco or mjwarp")
    missing = missing_gpu_modules()
    if missing:
        raise HarnessError(
            f"--engine mjwarp needs the 'gpu' extra ({', '.join(missing)} not importable): "
            f"{GPU_EXTRA_HINT}; or run on the CPU engine (--engine mujoco)"
        )
    problem = device_problem(os.environ.get(DEVICE_ENV), cuda_count())
    if problem is not None:
        raise HarnessError(problem)


def write_engine(run_dir: Path, engine: str) -> None:
    """Record the run's engine (``--resume`` reads it back)."""
    from harness.writes import write_file  # links and special files refused, as every writer

    write_file(run_dir / ENGINE_FILE, engine + "\n", root=run_dir)


def recorded_engine(run_dir: Path, row_engines: Iterable[object] = ()) -> str:
    """The engine a run directory ran on: ``ENGINE_FILE``, else its rows' ``engine`` column
    (runs made before the file existed), else the CPU engine."""
    path = run_dir / ENGINE_FILE
    if path.is_file():
        return path.read_text(encoding="utf-8").strip() or DEFAULT_ENGINE
    engines = {str(engine) for engine in row_engines if engine}
    return engines.pop() if len(engines) == 1 else DEFAULT_ENGINE


def resume_engine(run_dir: Path, recorded: str, requested: str | None) -> str:
    """The engine of a resumed run: the recorded one; another ``requested`` is refused (one
    run, one engine: its rows would mix two engines' physics)."""
    if requested is not None and requested != recorded:
        raise HarnessError(
            f"{run_dir}: the run executes on engine {recorded!r}; --resume keeps it (drop "
            f"--engine {requested}, or start a new run with --out)"
        )
    return recorded
