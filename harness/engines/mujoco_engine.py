"""The ``mujoco`` engine: the CPU executor (``harness.pick.executor``) in the episode's scene."""

from __future__ import annotations

from harness.engines.base import Execution, ExecutionJob
from harness.pick.executor import PickExecutor


class MujocoEngine:
    """One world on CPU MuJoCo (float64), stepped by the control loop: today's rows."""

    name = "mujoco"

    def execute(self, job: ExecutionJob) -> Execution:
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
