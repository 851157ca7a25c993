"""A batched engine's signals judged into a ``PickOutcome``, with the CPU executor's rules.

The measurements are taken at the control steps the CPU executor takes them (the schedule says
which: ``harness.engines.mjwarp.schedule``) and judged by the same verdict terms
(``harness.pick.verdict``: ``closing_terms``, the semantics' ``verdict_terms``,
``validity_terms``) and the same tug ladder (``harness.pick.validity.tug_ladder``, answered from
the rungs the batch ran: ``harness.engines.mjwarp.tug``): no second copy of the reference or
validity checks lives here, only the reading of the signal rows.
Not reproduced: strict's robot-environment collision check during the motion (no collision
model on the device; ``collisions`` stays empty) and the event log / trace.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from harness.engines.mjwarp.schedule import DeviceJob, ExecutionSchedule
from harness.engines.mjwarp.signals import (
    EE_MAT,
    EE_POS,
    FORCE_LEFT,
    FORCE_RIGHT,
    JOINT_SPEED,
    OBJ_POS,
    OBJ_VEL,
    PENETRATION,
    HoldWindow,
    object_in_tcp,
    object_pose_in_tcp,
    running_peak,
    unstable_reason,
    unstable_rows,
)
from harness.engines.mjwarp.tug import Rung, walk
from harness.pick.executor_validity import judged_validity, stopped_validity
from harness.pick.outcome import PickOutcome, ValidityMeasure
from harness.pick.validity import TUG_MAX_SLIP, RungOutcome, pose_drift
from harness.pick.verdict import VerdictTerm, closing_terms, first_failure


def _forces(row: np.ndarray) -> tuple[float, float]:
    return float(row[FORCE_LEFT]), float(row[FORCE_RIGHT])


def _tcp_error(job: DeviceJob, row: np.ndarray) -> float:
    """``PickExecutor._tcp_error`` on a signal row."""
    axis, offset = job.approach_index, job.tcp_offset
    planned = job.T_world_grasp
    R = row[EE_MAT].reshape(3, 3)
    p_planned = planned[:3, 3] + planned[:3, axis] * offset
    p_executed = row[EE_POS] + R[:, axis] * offset
    return float(np.linalg.norm(p_executed - p_planned))


class _Judge:
    """Walks the signal rows as the CPU loop walks its control steps."""

    def __init__(self, job: DeviceJob, schedule: ExecutionSchedule, steps: np.ndarray) -> None:
        self.job, self.schedule, self.steps = job, schedule, steps
        self.pick = job.task.pick
        self.out = PickOutcome()
        self.failed_term = ""
        self.substeps = sum(schedule.chunk_sizes)
        self.timestep = schedule.control_dt / self.substeps

    def fail(self, term: VerdictTerm | None) -> bool:
        if term is None:
            return False
        if not self.out.failure_reason:
            self.failed_term = term.name
            self.out.failure_reason, self.out.message = term.reason, term.message
        return True

    def measure(self, row: np.ndarray) -> None:
        """``PickExecutor._measure``."""
        out = self.out
        out.verdict_forces = _forces(row)
        out.verdict_joint_speed = float(row[JOINT_SPEED])
        out.verdict_object_speed = float(np.max(np.abs(row[OBJ_VEL])))
        out.lift_height_m = float(row[OBJ_POS][2] - self.job.object_init_position[2])

    def motion(self) -> bool:
        """The command list: True when the verdict was reached. The CPU loop's walk, in one
        pass: it stops at the first unstable row, or at the closing step when a closing term
        fails; the peaks are taken over the rows up to where it stopped."""
        out, schedule, steps = self.out, self.schedule, self.steps
        last = schedule.verdict_step if schedule.verdict_step >= 0 else schedule.steps - 1
        out.object_z_before = math.nan
        bad = unstable_rows(steps[: last + 1])
        unstable_at = int(np.argmax(bad)) if bad.any() else -1
        end = last if unstable_at < 0 else unstable_at
        reached = False
        stopped_at_closing = False
        close = schedule.close_step
        if 0 <= close <= end and close != unstable_at and self.closing(steps[close]):
            end, stopped_at_closing = close, True
        if not stopped_at_closing:
            if unstable_at >= 0:
                reason = unstable_reason(steps[unstable_at])
                out.failure_reason, out.message = "sim_unstable", reason or ""
            elif schedule.verdict_step >= 0:
                self.measure(steps[schedule.verdict_step])
                if not self.job.semantics.hold_after_list:
                    self.fail(first_failure(self.job.semantics.verdict_terms(self.pick, out)))
                reached = True
        walked = steps[: end + 1]
        out.max_joint_vel = running_peak(out.max_joint_vel, walked[:, JOINT_SPEED])
        speeds = np.linalg.norm(walked[:, OBJ_VEL], axis=1)
        out.max_object_vel = running_peak(out.max_object_vel, speeds)
        out.table_penetration_m = running_peak(out.table_penetration_m, walked[:, PENETRATION])
        return self.finish(end, reached)

    def closing(self, row: np.ndarray) -> bool:
        """The executor's measurements at the end of the closing window (``row``); True when a
        closing term failed (the command list stops there)."""
        out = self.out
        forces = _forces(row)
        out.tcp_grasp_error_m = _tcp_error(self.job, row)
        out.contact_during_close = max(forces) > 0.0
        out.finger_force_left_n, out.finger_force_right_n = forces
        out.T_tcp_object_closed = object_pose_in_tcp(row)
        return self.job.semantics.check_closing_forces and self.fail(
            first_failure(closing_terms(self.pick, forces))
        )

    def finish(self, step: int, reached: bool) -> bool:
        """The end of the command list at row ``step``: the timeout when the verdict was not
        reached, the step counts, the object's height; returns ``reached``."""
        out, steps = self.out, self.steps
        if not reached and not out.failure_reason:
            out.failure_reason = "timeout"
            out.message = (
                f"episode length limit ({self.job.task.max_episode_length} control steps) reached"
            )
        out.control_steps = step + 1
        out.sim_steps = out.control_steps * self.substeps
        out.sim_time_s = out.sim_steps * self.timestep
        out.object_z_after = float(steps[step][OBJ_POS][2])
        if not math.isfinite(out.lift_height_m):
            self.measure(steps[step])
        out.success = not out.failure_reason
        return reached

    def validity(self, window: HoldWindow, rungs: Mapping[Rung, RungOutcome] | None) -> None:
        """``run_validity_phase`` on the rows after the motion and the tug rungs' outcomes."""
        out, steps = self.out, self.steps
        after = steps[self.schedule.verdict_step + 1 : self.schedule.steps, PENETRATION]
        out.table_penetration_m = running_peak(out.table_penetration_m, after)
        measure = ValidityMeasure(
            table_penetration_m=out.table_penetration_m,
            closing_forces=(out.finger_force_left_n, out.finger_force_right_n),
        )
        end = steps[window.hold_end]
        reference = object_in_tcp(steps[window.rest_end])
        measure.ran = True
        closed = out.T_tcp_object_closed
        if closed is not None:  # the drift from the closing to the end of the hold
            drift = pose_drift(closed, object_pose_in_tcp(end))
            measure.hold_slip_m, measure.hold_rotation_rad = drift
        else:  # never closed: the hold alone
            measure.hold_slip_m = float(np.linalg.norm(object_in_tcp(end) - reference))
            measure.hold_rotation_rad = 0.0
        measure.finger_forces = _forces(end)
        measure.lift_height_m = float(end[OBJ_POS][2] - self.job.object_init_position[2])
        measure.object_speed = float(np.max(np.abs(end[OBJ_VEL])))
        measure.joint_speed = float(end[JOINT_SPEED])
        if unstable_reason(end) is not None:
            measure.hold_slip_m = math.inf
        if rungs is not None:
            ladder = walk(rungs)
            assert ladder.done, f"tug rungs missing: {ladder.missing}"
            measure.robustness_g, measure.tug_message = ladder.result
        else:
            measure.robustness_g, measure.tug_message = 0.0, "not tugged: the object is not held"
        out.validity = judged_validity(self.pick, measure)
        if self.job.semantics.hold_after_list:  # strict: this is the verdict
            out.slip_m, out.lift_height_m = measure.hold_slip_m, measure.lift_height_m
            out.verdict_forces = measure.finger_forces
            self.fail(first_failure(self.job.semantics.verdict_terms(self.pick, out)))
            out.success = not out.failure_reason


def held_in_tcp(steps: np.ndarray, window: HoldWindow) -> np.ndarray:
    """The object's position in the TCP frame at the end of the hold: what a rung's slip is
    measured from."""
    return object_in_tcp(steps[window.hold_end])


def rung_outcome(row: np.ndarray, held: np.ndarray) -> RungOutcome:
    """A tug rung's outcome from its end row (``ValidityPhase._tug``'s rule): survived when the
    slip since the end of the hold (``held``) is under ``TUG_MAX_SLIP``, both fingers still
    touch the object and the state is finite."""
    slip = float(np.linalg.norm(object_in_tcp(row) - held))
    between = min(_forces(row)) > 0.0
    survived = slip < TUG_MAX_SLIP and between and unstable_reason(row) is None
    return survived, slip, between


def needs_tug(steps: np.ndarray, window: HoldWindow, object_init_z: float) -> bool:
    """The CPU phase tugs when the object is lifted and the hold stayed finite."""
    end = steps[window.hold_end]
    lift = float(end[OBJ_POS][2] - object_init_z)
    return lift > 0.0 and unstable_reason(end) is None


def judge(
    job: DeviceJob,
    steps: np.ndarray,
    validity: bool,
    window: HoldWindow | None,
    rungs: Mapping[Rung, RungOutcome] | None,
) -> PickOutcome:
    """The outcome of one world: ``steps`` its signal rows (motion, then the validity window),
    ``rungs`` the outcomes of the tug rungs its ladder asked for (``rung_outcome``) when it was
    tugged."""
    state = _Judge(job, job.schedule, steps)
    reached = state.motion()
    if validity:
        if reached and window is not None:
            state.validity(window, rungs)
        else:
            measure = ValidityMeasure(
                table_penetration_m=state.out.table_penetration_m,
                closing_forces=(state.out.finger_force_left_n, state.out.finger_force_right_n),
            )
            state.out.validity = stopped_validity(measure, state.failed_term, state.out.message)
    return state.out


def judge_started(
    job: DeviceJob,
    steps: np.ndarray,
    warm_row: np.ndarray,
    validity: bool,
    window: HoldWindow | None,
    rungs: Mapping[Rung, RungOutcome] | None,
) -> PickOutcome:
    """``judge``, after the warm-up's row is checked: a world that was unstable before its
    motion started ends ``sim_unstable``."""
    reason = unstable_reason(warm_row)
    if reason is not None:
        return PickOutcome(failure_reason="sim_unstable", message=reason)
    return judge(job, steps, validity, window, rungs)
