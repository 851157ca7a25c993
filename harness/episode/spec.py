"""What defines one episode (``EpisodeSpec``).

A light module (the task config and the ids, no MuJoCo): the sweep's expansion and the runners
(``harness.runs``) build and pass specs without loading the simulator or the planners. What an
episode leaves is ``harness.episode.result.EpisodeResult``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from harness.config import TaskConfig
from harness.episode.ids import episode_id


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
    # Make the viewers' trace (``EpisodeResult.trace``). Off where nothing reads it (a sweep
    # worker's episode that no recording policy can want): the row is the same, the episode
    # cheaper.
    trace: bool = True

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
