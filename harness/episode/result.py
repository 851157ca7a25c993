"""What one episode leaves (``EpisodeResult``): its row, and its trace and scene when it got
that far."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from harness.episode.spec import EpisodeSpec
from harness.episode.trace import EpisodeTrace
from harness.sim import Scene


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
    # Answered partly from evaluations shared with earlier episodes
    # (``harness.episode.candidate_cache``): the row is complete, the trace is not kept.
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
