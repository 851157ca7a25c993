"""Execution engines behind one protocol (``harness.engines.base``): ``mujoco`` (CPU, one
world) and ``mjwarp`` (MuJoCo Warp, many worlds in lockstep; the optional extra ``gpu``)."""

from __future__ import annotations

from typing import Any

from harness.engines.base import ENGINE_NAMES, Execution, ExecutionEngine, ExecutionJob
from harness.errors import HarnessError

__all__ = [
    "ENGINE_NAMES",
    "Execution",
    "ExecutionEngine",
    "ExecutionJob",
    "engine_for",
    "register_engine",
]

_ENGINES: dict[str, Any] = {}


def register_engine(engine: ExecutionEngine) -> None:
    """Make ``engine`` the one ``engine_for(engine.name)`` returns in this process (benchmarks
    register a collecting engine that keeps the jobs instead of running them)."""
    _ENGINES[engine.name] = engine


def engine_for(name: str) -> ExecutionEngine:
    """The engine of a name, one per process (the mjwarp engine keeps its device models)."""
    if name not in ENGINE_NAMES and name not in _ENGINES:
        raise HarnessError(f"unknown engine {name!r}: choose one of {', '.join(ENGINE_NAMES)}")
    engine = _ENGINES.get(name)
    if engine is None:
        if name == "mujoco":
            from harness.engines.mujoco_engine import MujocoEngine

            engine = MujocoEngine()
        else:
            from harness.engines.mjwarp.engine import MjwarpEngine

            engine = MjwarpEngine()
        _ENGINES[name] = engine
    return engine
