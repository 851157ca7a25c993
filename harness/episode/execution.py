"""The last stages of an episode: the chosen candidate's executed plan, and its execution.

4. The executed plan, planned and timed (``harness.pick.execution_plan``,
   ``harness.planning.chain_timing``).
5. The reference's 10 warm-up steps, then the execution and its verdict
   (``harness.pick.execution_job``: CPU MuJoCo, ``harness.pick.executor``).

Their row columns are typed records (``harness.episode.records``): the ``ExecutedOutcome`` keeps
them (the planning wall time apart), so an episode that chooses the same candidate of the same
seed reuses them as they are.
"""

from __future__ import annotations

import math
import time

import numpy as np

from harness.episode import location, table_verdict
from harness.episode.candidate_cache import ExecutedOutcome
from harness.episode.planning import Choice, Planning
from harness.episode.records import (
    ExecutionColumns,
    MotionColumns,
    ReleaseColumns,
    RowRecord,
    TableReplayColumns,
)
from harness.episode.setup import WARMUP_TIME_S, EpisodeStopError
from harness.episode.trace import planned_tcp
from harness.pick.execution_job import ExecutionJob, execute_job
from harness.pick.execution_plan import PlanFailedError, plan_chosen
from harness.pick.targets import PickTargets
from harness.pick.validity import validity_columns
from harness.planning.chain_timing import time_plan
from harness.planning.timing import TimingError


def execute_chosen(planning: Planning, choice: Choice) -> ExecutedOutcome:
    """4 + 5. Plan and time the chosen candidate's motion and execute it: the records of the
    row columns it measured and how it ended, to keep for every point that chooses the same
    candidate."""
    records: list[RowRecord] = []
    planning.setup.ensure_synced()
    try:
        targets, planned, motion = _execution_plan(planning, choice)
        records.append(motion)
        measured, stop = _execute(planning, targets, planned)
        records.extend(measured)
    except EpisodeStopError as ended:
        stop = (ended.reason, ended.message)
        if ended.where is not None:  # kept with the outcome, for every point reusing it
            records.append(ended.where)
    return ExecutedOutcome(tuple(records), stop)


def _execution_plan(
    planning: Planning, choice: Choice
) -> tuple[PickTargets, tuple[np.ndarray, np.ndarray, np.ndarray] | None, MotionColumns]:
    """4. The executed plan, timed: its targets, the planned TCP path (for the trace; None
    when the spec wants no trace) and the motion's duration."""
    setup = planning.setup
    task, scene, arm = setup.task, setup.scene, setup.arm
    try:
        plan = plan_chosen(
            setup.planner, setup.pick, setup.semantics, planning.poses, choice.chosen,
            choice.T_base_grasp, setup.facts.q_now,
            setup.streams.execution(choice.chosen.pose_index),
        )  # fmt: skip
    except PlanFailedError as exc:
        where = location.plan_failure(exc.stage, exc.point)
        raise planning.stop("plan_failed", str(exc), where, exc.point) from None
    try:
        segments = time_plan(plan, scene, arm, task)
    except TimingError as exc:
        where = location.stage_failure("plan:timing")
        raise planning.stop("plan_failed", f"timing: {exc}", where) from None
    planning.record_plan_time()
    motion = MotionColumns(traj_duration_s=sum(s.duration for s in segments.values()))
    targets = PickTargets(plan.T_world_pregrasp, plan.T_world_grasp, plan.T_world_lift, segments)
    planned = None
    if setup.spec.trace:
        planned = planned_tcp(setup.planner.ik, scene, arm, segments, task.control_dt)
    return targets, planned, motion


def _execute(
    planning: Planning,
    targets: PickTargets,
    planned: tuple[np.ndarray, np.ndarray, np.ndarray] | None,
) -> tuple[tuple[RowRecord, ...], tuple[str, str] | None]:
    """5. The reference's 10 warm-up steps (robot holding its home), then execute and judge:
    the measured columns and, when the verdict failed, its reason and message."""
    setup = planning.setup
    scene, result = setup.scene, setup.result
    assert planning.plan_time is not None, "the plan is timed before it executes"
    result.timings["plan_s"] = planning.plan_time.plan_time_s
    clock = time.perf_counter()
    warmup_steps = max(1, round(WARMUP_TIME_S / scene.model.opt.timestep))
    setup.mark_stepped()
    result.timings["warmup_steps"] = float(warmup_steps)
    job = ExecutionJob(
        scene, setup.task, targets, setup.facts.object_init_position,
        planning.poses.lift_offset, setup.planner.checker, setup.semantics, warmup_steps,
        record=True, log_ctrl=setup.spec.log_ctrl,
        release_arm=setup.task.handover.arm if setup.task.handover is not None else None,
    )  # fmt: skip
    state = None if setup.task.physics.table_contact else table_verdict.start_state(scene)
    execution = execute_job(job)
    if execution.outcome is None:
        why = f"during the warm-up steps: {execution.warmup_unstable}"
        raise EpisodeStopError("sim_unstable", why, location.stage_failure("warmup"))
    outcome = execution.outcome
    result.timings["sim_s"] = time.perf_counter() - clock
    result.timings["validity_s"] = outcome.validity_time_s
    if execution.ctrl_log is not None:
        result.ctrl_log = execution.ctrl_log
    planning.finish_trace(outcome, targets, planned)
    execution_columns = ExecutionColumns(
        sim_time_s=outcome.sim_time_s,
        sim_steps=outcome.sim_steps,
        finger_force_left_n=outcome.finger_force_left_n,
        finger_force_right_n=outcome.finger_force_right_n,
        lift_height_m=outcome.lift_height_m,
        slip_m=outcome.slip_m,
        max_joint_vel=outcome.max_joint_vel,
        max_object_vel=outcome.max_object_vel,
        tcp_grasp_error_m=outcome.tcp_grasp_error_m,
    )
    replay = None
    if state is not None and table_verdict.needs_replay(setup.task, outcome):
        clock = time.perf_counter()
        replay = table_verdict.replay_on_physical_table(job, state)
        result.timings["table_replay_s"] = time.perf_counter() - clock
    judged, replayed = table_verdict.physical_verdict(setup.task, outcome.validity, replay)
    validity = validity_columns(execution.validity, outcome.table_penetration_m, judged)
    measured: tuple[RowRecord, ...] = (execution_columns, TableReplayColumns(replayed))
    if not math.isnan(outcome.first_gripper_force_n):  # a handover's release ran
        measured = (*measured, ReleaseColumns(outcome.first_gripper_force_n))
    stop = (outcome.failure_reason, outcome.message) if outcome.failure_reason else None
    if stop is None:
        return (*measured, validity), stop
    where = location.execution_failure(outcome.failure_phase, outcome.collision_pair)
    return (*measured, validity, where), stop
