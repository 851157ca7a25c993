"""The last stages of an episode: the chosen candidate's executed plan, and its execution.

4. The executed plan, planned and timed (``harness.pick.execution_plan``,
   ``harness.planning.chain_timing``).
5. The reference's 10 warm-up steps, then the execution and its verdict
   (``harness.pick.executor``).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from harness.episode.candidate_cache import WALL_TIME_COLUMNS, ExecutedOutcome
from harness.episode.planning import Choice, Planning
from harness.episode.setup import WARMUP_TIME_S, EpisodeStopError
from harness.episode.trace import planned_tcp
from harness.pick.execution_plan import PlanFailedError, plan_chosen
from harness.pick.executor import PickExecutor
from harness.pick.targets import PickTargets
from harness.pick.validity import validity_columns
from harness.planning.chain_timing import time_plan
from harness.planning.timing import TimingError


def _changed(before: dict[str, Any], key: str, value: Any) -> bool:
    if key not in before:
        return True
    old = before[key]
    if old is value:
        return False
    try:
        return bool(old != value)
    except (TypeError, ValueError):  # arrays and other values without a plain comparison
        return True


def execute_chosen(planning: Planning, choice: Choice) -> ExecutedOutcome:
    """4 + 5. Plan and time the chosen candidate's motion and execute it: the row columns it
    set and how it ended, to keep for every point that chooses the same candidate."""
    setup = planning.setup
    row = setup.row
    before = dict(row)
    stop: tuple[str, str] | None = None
    setup.ensure_synced()
    try:
        targets, planned = _execution_plan(planning, choice)
        _execute(planning, targets, planned)
    except EpisodeStopError as ended:
        stop = (ended.reason, ended.message)
    columns = {
        key: value
        for key, value in row.items()
        if key not in WALL_TIME_COLUMNS and _changed(before, key, value)
    }
    return ExecutedOutcome(columns, stop)


def _execution_plan(
    planning: Planning, choice: Choice
) -> tuple[PickTargets, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """4. The executed plan, timed: its targets and the planned TCP path (for the trace)."""
    setup = planning.setup
    task, scene, arm, row = setup.task, setup.scene, setup.arm, setup.row
    try:
        plan = plan_chosen(
            setup.planner, setup.pick, setup.semantics, planning.poses, choice.chosen,
            choice.T_base_grasp, setup.facts.q_now,
            setup.streams.execution(choice.chosen.pose_index),
        )  # fmt: skip
    except PlanFailedError as exc:
        raise planning.stop("plan_failed", str(exc)) from None
    try:
        segments = time_plan(plan, scene, arm, task)
    except TimingError as exc:
        raise planning.stop("plan_failed", f"timing: {exc}") from None
    planning.record_plan_time()
    row["traj_duration_s"] = sum(s.duration for s in segments.values())
    targets = PickTargets(plan.T_world_pregrasp, plan.T_world_grasp, plan.T_world_lift, segments)
    planned = planned_tcp(setup.planner.ik, scene, arm, segments, task.control_dt)
    return targets, planned


def _execute(
    planning: Planning,
    targets: PickTargets,
    planned: tuple[np.ndarray, np.ndarray, np.ndarray],
) -> None:
    """5. The reference's 10 warm-up steps (robot holding its home), then execute and judge."""
    setup = planning.setup
    scene, result, row = setup.scene, setup.result, setup.row
    result.timings["plan_s"] = row["plan_time_s"]
    clock = time.perf_counter()
    warmup_steps = max(1, round(WARMUP_TIME_S / scene.model.opt.timestep))
    warmup_ctrl = scene.data.ctrl.copy()
    setup.mark_stepped()
    scene.step(warmup_steps)
    result.timings["warmup_steps"] = float(warmup_steps)
    if (reason := scene.unstable()) is not None:
        raise EpisodeStopError("sim_unstable", f"during the warm-up steps: {reason}")
    executor = PickExecutor(
        scene, setup.task, targets, setup.facts.object_init_position,
        planning.poses.lift_offset, setup.planner.checker,
        record=True, log_ctrl=setup.spec.log_ctrl, semantics=setup.semantics,
    )  # fmt: skip
    outcome = executor.run()
    result.timings["sim_s"] = time.perf_counter() - clock
    result.timings["validity_s"] = outcome.validity_time_s
    if executor.ctrl_log is not None:
        result.ctrl_log = [(warmup_steps, warmup_ctrl), *executor.ctrl_log]
    planning.finish_trace(outcome, targets, planned)
    row.update(
        {
            "sim_time_s": outcome.sim_time_s,
            "sim_steps": outcome.sim_steps,
            "finger_force_left_n": outcome.finger_force_left_n,
            "finger_force_right_n": outcome.finger_force_right_n,
            "lift_height_m": outcome.lift_height_m,
            "slip_m": outcome.slip_m,
            "max_joint_vel": outcome.max_joint_vel,
            "max_object_vel": outcome.max_object_vel,
            "tcp_grasp_error_m": outcome.tcp_grasp_error_m,
        }
    )
    row.update(validity_columns(executor.validity, outcome.table_penetration_m, outcome.validity))
    if outcome.failure_reason:
        raise EpisodeStopError(outcome.failure_reason, outcome.message)
