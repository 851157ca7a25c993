"""The execution engine protocol: what an engine is given (``ExecutionJob``) and returns.

Planning (reset, candidates, feasibility, plan, timing) stays on the CPU; an engine executes the
chosen plan and returns a ``PickOutcome`` judged by the one set of verdict terms
(``harness.pick.verdict``). ``mujoco`` runs today's CPU executor in the episode's own scene;
``mjwarp`` replays the executor's control schedule on MuJoCo Warp worlds in lockstep and judges
the signals it recorded (``harness.engines.mjwarp.judge``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from harness.config import TaskConfig
from harness.pick.outcome import PickOutcome
from harness.pick.semantics import Semantics
from harness.pick.targets import PickTargets
from harness.planning.collision import CollisionChecker
from harness.sim import Scene

ENGINE_NAMES = ("mujoco", "mjwarp")


@dataclass
class ExecutionJob:
    """One chosen plan to execute: the scene holds the state to start from (before the warm-up
    steps, robot at home), the targets carry the timed segments."""

    scene: Scene
    task: TaskConfig
    targets: PickTargets
    object_init_position: np.ndarray
    lift_offset: float
    checker: CollisionChecker | None
    semantics: Semantics
    warmup_steps: int
    record: bool = True
    log_ctrl: bool = False
    # A handover's second pick: the arm whose gripper opens before the validity phase
    # (harness.pick.release); None for every other pick.
    release_arm: str | None = None


@dataclass
class Execution:
    """What an engine returns: the outcome (None when the warm-up already diverged, with
    ``warmup_unstable`` saying why), whether the validity phase applied, the control log."""

    outcome: PickOutcome | None
    validity: bool
    warmup_unstable: str | None = None
    ctrl_log: list[tuple[int, np.ndarray]] | None = None

    @classmethod
    def of_batch(cls, outcome: PickOutcome, validity: bool) -> Execution:
        """The ``Execution`` of a batched engine's outcome, which reports a warm-up that
        diverged as ``sim_unstable`` before any control step."""
        if outcome.failure_reason == "sim_unstable" and outcome.control_steps == 0:
            return cls(None, validity, warmup_unstable=outcome.message)
        return cls(outcome, validity)


class ExecutionEngine(Protocol):
    """Executes chosen plans; ``name`` is the row's ``engine`` column."""

    name: str

    def execute(self, job: ExecutionJob) -> Execution:
        """Run the warm-up steps, then the pick, and judge it."""
        ...
