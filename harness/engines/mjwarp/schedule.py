"""The control schedule of an execution job, made without physics (for batched engines).

The CPU executor decides when a command pops from the end-effector pose it reads each control
step (``harness.pick.commands``). A batched engine cannot wait for each world's pose on the host,
so the schedule is made ahead on the CPU by the executor itself (``PickExecutor``, the one
command list and servo schedule) run on a *kinematic* copy of the scene: each physics chunk sets
the arm joints to their servo setpoints and runs ``mj_kinematics`` instead of ``mj_step``. The
commands then pop when the *commanded* pose reaches its target: at the end of each segment
rather than a few control steps later when the real arm, lagging its setpoints, gets there. The
verdicts are not taken here (the physics is not run); the schedule records where they are due.
What this timing difference does to the outcomes is measured (docs/engines.md, agreement).

The kinematic run computes only what the schedule depends on (``lean``): the pose tests that pop
commands. It skips what the executor measures for its row and nobody reads here (the device
measures them itself): the table penetration, the joint and object speeds; and it moves the
joints to their setpoints and runs ``mj_kinematics`` only when a pose is read (once per control
step, not once per servo chunk).
``lean=False`` runs the executor's every measurement, for the test that the schedule is the same.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import mujoco
import numpy as np

from harness.config import TaskConfig
from harness.engines.base import ExecutionJob
from harness.engines.mjwarp.contact import contact_key
from harness.pick.executor import PickExecutor
from harness.pick.penetration import TablePenetration
from harness.pick.semantics import Semantics
from harness.pick.verdict import VerdictTerm
from harness.sim import Scene
from harness.sim.masks import contact_bits
from harness.sim.queries import T_from_pos_mat


@dataclass
class ExecutionSchedule:
    """Per control step, the servo targets of each physics chunk, and the steps that matter.

    ``ctrl`` is (steps, chunks, nu): the motion up to the verdict and, when the validity phase
    applies, the rest of the planned motion; after it every servo holds ``ctrl[-1, -1]``.
    ``close_step`` is the control step at whose end the closing ended (-1: never),
    ``verdict_step`` the one at whose end the list emptied (-1: the episode timed out at
    ``max_episode_length``), both 0-based."""

    ctrl: np.ndarray
    chunk_sizes: list[int]
    warmup_steps: int
    warmup_ctrl: np.ndarray
    close_step: int
    verdict_step: int
    control_dt: float

    @property
    def steps(self) -> int:
        return int(self.ctrl.shape[0])

    @property
    def hold_ctrl(self) -> np.ndarray:
        return self.ctrl[-1, -1]


class _NoPenetration(TablePenetration):
    """A ``TablePenetration`` that measures nothing (the device measures the depth), and costs
    nothing to make (no per-geom tables)."""

    def __init__(self) -> None:
        pass

    def depth(self, data: mujoco.MjData) -> float:
        return 0.0


class _ScheduleExecutor(PickExecutor):
    """The executor on a kinematic scene: judges nothing, notes when the verdicts are due."""

    close_step = -1
    verdict_step = -1
    lean = True

    def _table_penetration(self, scene: Scene) -> TablePenetration:
        return _NoPenetration() if self.lean else super()._table_penetration(scene)

    def _track_penetration(self) -> None:
        if not self.lean:
            super()._track_penetration()

    def _object_speed(self) -> float:
        return super()._object_speed() if not self.lean else 0.0

    def judge(self, terms: tuple[VerdictTerm, ...]) -> bool:
        return False  # verdicts are taken on the engine's signals (harness.engines.mjwarp.judge)

    def _measure(self) -> tuple[float, float]:
        if self.verdict_step < 0 and self.head >= len(self.commands):  # the list emptied
            self.verdict_step = self.step - 1
        return (0.0, 0.0)

    def _progress(self, forces: tuple[float, float]) -> bool:
        closed_before = math.isfinite(self.out.tcp_grasp_error_m)
        done = super()._progress(forces)
        if not closed_before and math.isfinite(self.out.tcp_grasp_error_m):
            self.close_step = self.step - 1
        return done


class _MeasuringScheduleExecutor(_ScheduleExecutor):
    """The schedule's executor with every measurement of the CPU executor (``lean=False``)."""

    lean = False


def kinematic_scene(scene: Scene, lean: bool = True) -> Scene:
    """A copy of the scene on its own MjData whose ``step`` moves the arm joints to their servo
    setpoints (no dynamics, no contacts: no forces, never unstable). ``lean``: the joints are
    moved and the body poses brought up to date when ``T_world_body`` reads one (the same
    poses: the executor sets ``ctrl`` only before a ``step``, so the setpoints then are those
    of the last ``step``, and ``mj_kinematics`` is a function of ``qpos``), and the joint
    speed reads 0."""
    kin = copy.copy(scene)
    data = copy.copy(scene.data)
    kin.data = data
    model = scene.model
    arms = list(scene.arms.values())
    stale = [False]

    def to_setpoints() -> None:
        for handles in arms:
            data.qpos[handles.active_qpos] = data.ctrl[handles.active_actuators]

    def step(nstep: int) -> None:
        if lean:
            stale[0] = True
        else:
            to_setpoints()
            mujoco.mj_kinematics(model, data)

    kin.step = step  # type: ignore[method-assign]
    kin.finger_forces = lambda arm, object_name: (0.0, 0.0)  # type: ignore[method-assign]
    kin.unstable = lambda: None  # type: ignore[method-assign]
    if lean:

        def T_world_body(body: int) -> np.ndarray:
            if stale[0]:
                to_setpoints()
                mujoco.mj_kinematics(model, data)
                stale[0] = False
            return T_from_pos_mat(data.xpos[body], data.xmat[body])

        kin.T_world_body = T_world_body  # type: ignore[method-assign]
        kin.robot_joint_speed = lambda: 0.0  # type: ignore[method-assign]
    return kin


def build_schedule(job: ExecutionJob, lean: bool = True) -> ExecutionSchedule:
    """Run the executor kinematically from the job's start state; see the module doc."""
    scene = kinematic_scene(job.scene, lean)
    warmup_ctrl = scene.data.ctrl.copy()
    executor_type = _ScheduleExecutor if lean else _MeasuringScheduleExecutor
    executor = executor_type(
        scene, job.task, job.targets, job.object_init_position, job.lift_offset, None,
        record=False, log_ctrl=True, semantics=job.semantics,
    )  # fmt: skip
    validity = executor.validity
    executor.validity = False
    executor.run()
    if validity and executor.verdict_step >= 0:
        executor.post = "validity:finish"
        while not executor.finish_step():
            pass
    log = executor.ctrl_log
    assert log is not None
    chunks = len(executor.chunk_sizes)
    ctrl = np.asarray([c for _, c in log], dtype=float).reshape(-1, chunks, len(warmup_ctrl))
    return ExecutionSchedule(
        ctrl, list(executor.chunk_sizes), job.warmup_steps, warmup_ctrl,
        executor.close_step, executor.verdict_step, executor.control_dt,
    )  # fmt: skip


@dataclass
class DeviceJob:
    """An execution job in plain arrays (picklable: planning workers send it to the process that
    owns the device): the start state, the schedule, what the verdicts need of the plan, and
    the contact bits of every geom the job runs with (``harness.sim.masks.contact_bits``: the
    table verdict's replay runs the job again with robot-table contact on;
    ``harness.engines.mjwarp.contact``)."""

    task: TaskConfig
    semantics: Semantics
    object_init_position: np.ndarray
    T_world_grasp: np.ndarray
    approach_index: int
    tcp_offset: float
    state: dict[str, np.ndarray]
    schedule: ExecutionSchedule
    contact: np.ndarray

    @property
    def contact_key(self) -> str:
        """The name of the job's contact bits: jobs of one model variant share it."""
        return contact_key(self.contact)


def device_job(job: ExecutionJob) -> DeviceJob:
    """The job's start state, schedule (``build_schedule``) and contact bits (the scene's
    model's as they are at the call) as a ``DeviceJob``."""
    d = job.scene.data
    convention = job.scene.robot.convention
    state = {
        name: np.array(getattr(d, name))
        for name in ("qpos", "qvel", "qacc_warmstart", "ctrl", "mocap_pos", "mocap_quat")
    }
    return DeviceJob(
        job.task, job.semantics, np.asarray(job.object_init_position, dtype=float),
        job.targets.T_world_grasp.copy(), int(convention.approach_index),
        float(job.task.pick.tcp_offset or convention.tcp_offset), state, build_schedule(job),
        contact_bits(job.scene.model),
    )  # fmt: skip
