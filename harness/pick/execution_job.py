"""One chosen plan executed in MuJoCo: what is given (``ExecutionJob``), what comes back
(``Execution``), and ``execute_job``, which runs the reference's warm-up steps and then the CPU
executor (``harness.pick.executor``) in the episode's own scene.

Planning (reset, candidates, feasibility, plan, timing) happens before; the outcome is judged by
the one set of verdict terms (``harness.pick.verdict``). The table verdict's replay
(``harness.episode.table_verdict``) executes the same job a second time on a table-physical
variant of the scene.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from harness.config import TaskConfig
from harness.pick.executor import PickExecutor
from harness.pick.outcome import PickOutcome
from harness.pick.semantics import Semantics
from harness.pick.targets import PickTargets
from harness.planning.collision import CollisionChecker
from harness.sim import Scene


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
    """What an execution returns: the outcome (None when the warm-up already diverged, with
    ``warmup_unstable`` saying why), whether the validity phase applied, the control log."""

    outcome: PickOutcome | None
    validity: bool
    warmup_unstable: str | None = None
    ctrl_log: list[tuple[int, np.ndarray]] | None = None


def execute_job(job: ExecutionJob) -> Execution:
    """Run the warm-up steps (robot holding its home), then the pick, and judge it."""
    scene = job.scene
    warmup_ctrl = scene.data.ctrl.copy()
    scene.step(job.warmup_steps)
    if (reason := scene.unstable()) is not None:
        return Execution(None, False, warmup_unstable=reason)
    executor = PickExecutor(
        scene, job.task, job.targets, job.object_init_position, job.lift_offset,
        job.checker, record=job.record, log_ctrl=job.log_ctrl, semantics=job.semantics,
        release_arm=job.release_arm,
    )  # fmt: skip
    outcome = executor.run()
    ctrl_log = None
    if executor.ctrl_log is not None:
        ctrl_log = [(job.warmup_steps, warmup_ctrl), *executor.ctrl_log]
    return Execution(outcome, executor.validity, ctrl_log=ctrl_log)
