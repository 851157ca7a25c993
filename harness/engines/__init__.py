"""Execution engines behind one protocol (``harness.engines.base``): ``mujoco`` (CPU, one
world) and ``mjwarp`` (MuJoCo Warp, many worlds in lockstep; the optional extra ``gpu``)."""

from __future__ import annotations

from typing import Any

from harness.engines.base import ENGINE_NAMES, Execution, ExecutionEngine, ExecutionJob
from harness.errors import HarnessError

__all__ = ["ENGINE_NAMES", "Execution", "ExecutionEngine", "ExecutionJob", "engine_for"]

_ENGINES: dict[str, Any] = {}


def engine_for(name: str) -> ExecutionEngine:
    """The engine of a name, one per process (the mjwarp engine keeps its device models)."""
    if name not in ENGINE_NAMES:
        raise HarnessError(f"unknown engine {name!r}: choose one of {', '.join(ENGINE_NAMES)}")
    engine = _ENGINES.get(name)
    if engine is None:
        if name == "mujoco":
            from harness.engines.mujoco_engine import MujocoEngine

            engine = MujocoEngine()
        else:
            from harness.engines.mjwarp_engine import MjwarpEngine

            engine = MjwarpEngine()
        _ENGINES[name] = engine
    return engine
