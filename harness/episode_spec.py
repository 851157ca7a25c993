"""What defines one episode (``EpisodeSpec``) and what it leaves (``EpisodeResult``).

Kept apart from ``harness.episode`` so that the episode's stages (``harness.episode_stages``)
and the runners can name them without importing the whole pipeline.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from harness.config import TaskConfig
from harness.episode_ids import episode_id
from harness.episode_trace import EpisodeTrace
from harness.sim import Scene


@dataclass(frozen=True)
class EpisodeSpec:
    """Everything that defines one episode."""

    task: TaskConfig
    seed: int = 0
    episode_index: int = 0
    point_id: int = 0
    point: dict[str, Any] = field(default_factory=dict)
    run: str = ""
    record: bool = False
    episode_id: str | None = None
    log_ctrl: bool = False  # keep the physics control log (benchmarks replay it)
    task_name: str | None = None  # the sweep's name of the task (the task's own when None)
    engine: str = "mujoco"  # the execution engine (harness.engines): mujoco | mjwarp

    @property
    def resolved_task_name(self) -> str:
        """The task name the row reports: ``task_name``, else the task's own."""
        return self.task_name or self.task.name

    @property
    def resolved_id(self) -> str:
        """``episode_id``, else the id a sweep gives (task name, point, episode index)."""
        return self.episode_id or episode_id(
            self.resolved_task_name, self.point, self.episode_index
        )


@dataclass
class EpisodeResult:
    """The row plus, when the episode got that far, the trace and the scene it ran in."""

    spec: EpisodeSpec
    row: dict[str, Any]
    trace: EpisodeTrace | None = None
    scene: Scene | None = None
    # Wall time per stage (setup: scene + reset, plan: selection to timed plan, sim: execution)
    # and the physics steps of the reset's settling.
    timings: dict[str, float] = field(default_factory=dict)
    ctrl_log: list[tuple[int, np.ndarray]] | None = None
    # Answered partly from evaluations shared with earlier episodes (``harness.candidate_cache``):
    # the row is complete, the trace is not kept.
    shared: bool = False

    @property
    def success(self) -> bool:
        return bool(self.row.get("success"))

    @property
    def failure_reason(self) -> str:
        return str(self.row.get("failure_reason", ""))

    @property
    def model(self) -> mujoco.MjModel | None:
        return self.scene.model if self.scene is not None else None
