"""The Pick skill executed in MuJoCo: the control loop that runs the reference command list.

The command list and its progress rules are ``harness.pick.commands`` (docs/reference-pick-skill.md
sections 6
and 7); the success checks are ``harness.pick.verdict``; which of them apply, and whether robot
collisions are checked, is ``harness.pick.semantics``. This module steps the physics and moves
through the list.

Execution: the control loop runs in Python once per control step; the servo setpoints and
chunking are ``harness.pick.servo``. The validity phase that follows the verdict, and its
verdict, are ``harness.pick.executor_validity``. ``harness.pick.execution_job`` runs it after
the warm-up steps.
"""

from __future__ import annotations

import time

import numpy as np

from harness.config import TaskConfig
from harness.failures import FailureReason
from harness.pick.commands import (
    HOLD_FUNCTIONS,
    IDLE_POP_STEPS,
    SEGMENT_OF_TARGET,
    build_commands,
    pose_reached,
    target_moved,
)
from harness.pick.executor_validity import judged_validity, run_validity_phase
from harness.pick.outcome import PickOutcome
from harness.pick.penetration import TablePenetration
from harness.pick.recorder import TraceRecorder
from harness.pick.release import RELEASE_STEPS, release_gripper
from harness.pick.semantics import Semantics
from harness.pick.servo import SERVO_CHUNK_S, ServoTiming
from harness.pick.targets import PickTargets
from harness.pick.validity import phase_steps, validity_enabled
from harness.pick.verdict import VerdictTerm, closing_terms, first_failure
from harness.planning.collision import CollisionChecker, Phase
from harness.sim import Scene
from harness.transforms import invert_T

__all__ = ["EXECUTION_PENETRATION", "FINISH_STEPS", "SERVO_CHUNK_S", "PickExecutor"]

FINISH_STEPS = 300  # recorder rows kept for the motion still playing after the list empties
# Strict: a robot-environment contact during execution is a collision beyond this penetration
# (m). Plans keep 0.1 mm; tracking lag lets a finger planned to graze the table dip a little.
EXECUTION_PENETRATION = 0.002


class PickExecutor:
    """Runs the command list on the scene, control step by control step; see the module doc."""

    def __init__(
        self,
        scene: Scene,
        task: TaskConfig,
        targets: PickTargets,
        object_init_position: np.ndarray,
        lift_offset: float,
        checker: CollisionChecker | None = None,
        record: bool = True,
        log_ctrl: bool = False,
        semantics: Semantics | None = None,
        release_arm: str | None = None,
    ) -> None:
        self.scene = scene
        # A handover's second pick: this arm's gripper opens before the validity phase.
        self.release_arm = release_arm
        self.data = scene.data
        # (steps, ctrl) per physics chunk, for replaying the same physics without the harness.
        self.ctrl_log: list[tuple[int, np.ndarray]] | None = [] if log_ctrl else None
        self.task = task
        self.pick = task.pick
        self.semantics = semantics if semantics is not None else Semantics.from_pick(task.pick)
        self.arm = task.arm
        self.handles = scene.arms[task.arm]
        self.arm_spec = scene.robot.arm(task.arm)
        self.targets = targets
        self.object_name = task.target_object.name
        self.obj = scene.objects[self.object_name]
        self.object_init_position = np.asarray(object_init_position, dtype=float)
        self.commands = build_commands(task.pick, lift_offset)
        self.checker = checker if self.semantics.check_collisions else None
        self.servo = ServoTiming(scene.model, self.handles, task.control_dt)
        self.timestep = self.servo.timestep
        self.substeps = self.servo.substeps
        self.control_dt = self.servo.control_dt
        self.chunk_sizes = self.servo.chunk_sizes
        # The validity phase runs after the reference verdict (always under strict, whose
        # success it is); its steps are recorded too.
        self.validity = validity_enabled(task.pick)
        capacity = (task.max_episode_length + 2) * len(self.chunk_sizes)
        if self.validity:
            capacity += FINISH_STEPS * len(self.chunk_sizes)
            capacity += phase_steps(task.pick.hold_time, self.control_dt)
            if release_arm is not None:
                capacity += 4 * RELEASE_STEPS  # the ramp (at most 2 x) and the wait
        self.recorder = (
            TraceRecorder(scene, self.arm, self.object_name, capacity) if record else None
        )
        # Loop state.
        self.out = PickOutcome()
        self.step = 0
        self.head = 0
        self.idle = 0  # the reference controller's num_last_cmd
        self.planned_target: np.ndarray | None = None  # the last target that reset ``idle``
        self.previous_target = "current"
        self.pending_segment: str | None = None
        self.started_segments: set[str] = set()
        self.arm_plan: np.ndarray | None = None
        self.arm_row = 0
        self.arm_segment = ""
        self.gripper_plan: np.ndarray | None = None
        self.gripper_row = 0
        self.gripper_state: str | None = None
        self.post: str | None = None  # the phase label once the list is empty
        self.failed_term = ""  # the name of the verdict term that failed the episode
        self.forces: tuple[float, float] = (0.0, 0.0)
        self.penetration = self._table_penetration(scene)

    @property
    def time(self) -> float:
        return self.out.sim_steps * self.timestep

    def _event(self, text: str) -> None:
        if self.recorder is not None:
            self.recorder.event(self.time, text)

    # -- commands -------------------------------------------------------------------------------

    def _target_pose(self, target: str, T_current: np.ndarray) -> np.ndarray:
        if target == "current":
            return T_current
        if target == "pregrasp":
            return self.targets.T_world_pregrasp
        if target == "grasp":
            return self.targets.T_world_grasp
        assert self.targets.T_world_lift is not None
        return self.targets.T_world_lift

    def _start_command(self, index: int) -> None:
        """The head command changed: queue its segment, apply its gripper action."""
        command = self.commands[index]
        if command.event:
            self._event(f"{command.function}: {command.event}")
        if command.target != "current" and command.function not in HOLD_FUNCTIONS:
            T_target = self._target_pose(command.target, np.eye(4))
            if self.planned_target is None or target_moved(self.planned_target, T_target):
                self.planned_target = T_target
                self.idle = 0  # the reference re-plans here and resets num_last_cmd
        if command.target not in ("current", self.previous_target):
            segment = "retreat" if command.number == 10 else SEGMENT_OF_TARGET[command.target]
            if segment in self.targets.segments and segment not in self.started_segments:
                self.pending_segment = segment
        if command.gripper is not None and command.gripper != self.gripper_state:
            self.gripper_state = command.gripper
            d, h = self.data, self.handles
            current = float(d.ctrl[h.gripper_actuator])
            opening = command.gripper == "open"
            spec = self.arm_spec
            goal = spec.finger_open_position if opening else spec.finger_closed_position
            # A force-controlled grasp ends below the closed width: the servo then presses with
            # its force limit wherever the fingers stopped (GripperActuator.grasp).
            final = goal if opening else spec.finger_squeeze_position
            if abs(final - current) > 1e-6:
                self.gripper_plan = self.servo.gripper_setpoints(
                    current, goal, final, spec.gripper.speed, self.pick.gripper_change_steps
                )
                self.gripper_row = 0
                self._event(f"gripper {command.gripper}")

    def _reached(self, T_ee: np.ndarray, T_target: np.ndarray) -> bool:
        """The reference ``is_done`` pose test: ``|p - p*| < t_eps`` (m) and
        ``2 acos(min(|q . q*|, 1)) < o_eps`` (rad)."""
        return pose_reached(T_ee, T_target, self.pick.t_eps, self.pick.o_eps)

    def _tcp_error(self) -> float:
        """Distance between the executed and the planned TCP point at the grasp."""
        convention = self.scene.robot.convention
        axis = convention.approach_index
        offset = self.pick.tcp_offset or convention.tcp_offset
        planned = self.targets.T_world_grasp
        executed = self.scene.T_world_body(self.handles.ee_body)
        p_planned = planned[:3, 3] + planned[:3, axis] * offset
        p_executed = executed[:3, 3] + executed[:3, axis] * offset
        return float(np.linalg.norm(p_executed - p_planned))

    # -- one control step -----------------------------------------------------------------------

    def _control_step(self) -> None:
        d, h = self.data, self.handles
        if self.pending_segment is not None and self.arm_plan is None:
            segment = self.pending_segment
            self.arm_plan = self.servo.arm_setpoints(self.targets.segments[segment])
            self.arm_row = 0
            self.arm_segment = segment
            self.started_segments.add(segment)
            self.pending_segment = None
            self._event(f"segment {segment} ({self.targets.segments[segment].duration:.3f} s)")
        arm_plan, gripper_plan = self.arm_plan, self.gripper_plan
        out = self.out
        recorder = self.recorder
        phase = self._phase_label() if recorder is not None else ""
        forces = (0.0, 0.0)
        # Locals for the chunk loop (it runs ~5 times a control step, on every episode's
        # schedule): the ctrl view is the MjData buffer itself, valid across steps.
        ctrl, log, last = d.ctrl, self.ctrl_log, len(self.chunk_sizes) - 1
        arm_rows = arm_plan[self.arm_row] if arm_plan is not None else None
        gripper_rows = gripper_plan[self.gripper_row] if gripper_plan is not None else None
        for chunk, size in enumerate(self.chunk_sizes):
            if arm_rows is not None:
                ctrl[h.active_actuators] = arm_rows[chunk]
            if gripper_rows is not None:
                ctrl[h.gripper_actuator] = gripper_rows[chunk]
            if log is not None:
                log.append((size, ctrl.copy()))
            self.scene.step(size)
            out.sim_steps += size
            if recorder is not None or chunk == last:
                forces = self.scene.finger_forces(self.arm, self.object_name)
            if recorder is not None:  # one trace row per servo chunk (~10 ms)
                recorder.record(self.time, phase, forces)
        self.forces = forces
        self.step += 1
        out.max_joint_vel = max(out.max_joint_vel, self.scene.robot_joint_speed())
        out.max_object_vel = max(out.max_object_vel, self._object_speed())
        if arm_plan is not None:
            self.arm_row += 1
            if self.arm_row >= len(arm_plan):
                self.arm_plan = None
                if self.arm_segment == "approach":
                    error = self._tcp_error()
                    self._event(f"approach done, TCP {error * 1e3:.2f} mm from the planned grasp")
        elif self.head >= len(self.commands) or (
            self.commands[self.head].function not in HOLD_FUNCTIONS
        ):
            self.idle += 1  # no active trajectory (update_* commands hold without counting)
        if gripper_plan is not None:
            self.gripper_row += 1
            if self.gripper_row >= len(gripper_plan):
                self.gripper_plan = None

    def _phase_label(self) -> str:
        """The head command as ``function:target`` (or the strict post-phase)."""
        if self.head < len(self.commands):
            command = self.commands[self.head]
            return f"{command.function}:{command.target}"
        return self.post or "verdict"

    def _check_collisions(self) -> None:
        """Strict: robot-environment collisions at the executed configuration (check model,
        so they are seen even where the physics ignores robot-table contact)."""
        checker = self.checker
        assert checker is not None
        target = self.commands[min(self.head, len(self.commands) - 1)].target
        phase: Phase = "approach" if target == "grasp" else "transport"
        if target == "lift" or self.head >= len(self.commands) or self._attached():
            phase = "carry"
        checker.data.qpos[:] = self.data.qpos
        q = self.data.qpos[self.handles.active_qpos]
        pairs = checker.contacts(q, phase, EXECUTION_PENETRATION)
        if pairs:
            self.out.collisions.append(f"t={self.time:.3f}s {checker.describe(pairs)}")
            if self.out.collision_pair is None:
                self.out.collision_pair = checker.pair_names(pairs[0])

    def _attached(self) -> bool:
        """The attach event has passed: the object is in the hand (carry rules)."""
        return any(c.event == "attach" for c in self.commands[: self.head])

    def _progress(self, forces: tuple[float, float]) -> bool:
        """Pop at most one command; returns True when the list just became empty."""
        command = self.commands[self.head]
        T_ee = self.scene.T_world_body(self.handles.ee_body)
        if not (
            self._reached(T_ee, self._target_pose(command.target, T_ee))
            or self.idle > IDLE_POP_STEPS
        ):
            return False
        if command.target != "current":
            self.previous_target = command.target
        last_close = command.number == 6 and self.commands[self.head + 1].number != 6
        if last_close:
            # The grasp as executed: the arm has had the whole closing window to settle.
            self.out.tcp_grasp_error_m = self._tcp_error()
            self.out.contact_during_close = max(forces) > 0.0
            self.out.T_tcp_object_closed = self.object_pose_in_tcp()
            self.out.finger_force_left_n, self.out.finger_force_right_n = forces
            self._event(f"closed: finger forces {forces[0]:.2f} / {forces[1]:.2f} N")
            if self.semantics.check_closing_forces and self.judge(closing_terms(self.pick, forces)):
                return False
        self.head += 1  # the idle count carries on: only a new target resets it
        if self.head < len(self.commands):
            self._start_command(self.head)
            return False
        self._event("command list empty")
        return True

    def _fail(self, reason: FailureReason, message: str) -> None:
        if not self.out.failure_reason:
            self.out.failure_reason = reason
            self.out.message = message
            self.out.failure_phase = self._phase_label()

    # -- run ------------------------------------------------------------------------------------

    def run(self) -> PickOutcome:
        """Execute until the verdict, a failure, or the episode length limit."""
        out, d = self.out, self.data
        out.object_z_before = float(d.xpos[self.obj.body_id][2])
        self.penetration.depth(d)  # the baseline: where the robot stands before it moves
        # The controller's last planned target starts as the EE pose (its reset).
        self.planned_target = self.scene.T_world_body(self.handles.ee_body)
        self._start_command(0)
        done = False
        while not done and not out.failure_reason:
            self._control_step()
            self._track_penetration()
            reason = self.scene.unstable()
            if reason is not None:
                self._fail("sim_unstable", reason)
                break
            forces = self.forces
            if self.checker is not None:
                self._check_collisions()
            if self._progress(forces):
                self._measure()
                if not self.semantics.hold_after_list:
                    self.judge(self.semantics.verdict_terms(self.pick, out))
                done = True
            if not done and not out.failure_reason and self.step >= self.task.max_episode_length:
                self._fail(
                    "timeout",
                    f"episode length limit ({self.task.max_episode_length} control steps) reached",
                )
        out.control_steps = self.step
        out.sim_time_s = self.time
        out.object_z_after = float(d.xpos[self.obj.body_id][2])
        if not np.isfinite(out.lift_height_m):
            self._measure()
        out.success = not out.failure_reason
        if not self.semantics.hold_after_list:
            self._event(f"verdict: {'success' if out.success else out.failure_reason}")
        if self.validity:
            clock = time.perf_counter()
            released = None
            kept_steps = out.sim_steps
            if self.release_arm is not None and done:
                released = release_gripper(self, self.release_arm)
            run_validity_phase(self, verdict_reached=done)
            if released is not None and out.validity is not None:
                out.first_gripper_force_n = max(released)
                measure = out.validity.measure
                measure.first_gripper_force_n = out.first_gripper_force_n
                out.validity = judged_validity(self.pick, measure)  # with the release's term
                out.sim_steps = kept_steps  # the list's steps, as for any pick
            out.validity_time_s = time.perf_counter() - clock
        if self.recorder is not None:
            out.trace = self.recorder.finish()
            if out.validity is not None:
                out.trace.validity = out.validity.measure.trace
        return out

    # -- verdicts -------------------------------------------------------------------------------

    def _measure(self) -> tuple[float, float]:
        """Forces, speeds and lift at this instant (the verdict's inputs)."""
        out, d = self.out, self.data
        forces = self.scene.finger_forces(self.arm, self.object_name)
        out.verdict_forces = forces
        out.verdict_joint_speed = self.scene.robot_joint_speed()
        velocity = d.qvel[self.obj.dof_adr : self.obj.dof_adr + 3]
        out.verdict_object_speed = float(np.max(np.abs(velocity)))
        out.lift_height_m = float(d.xpos[self.obj.body_id][2] - self.object_init_position[2])
        return forces

    def judge(self, terms: tuple[VerdictTerm, ...]) -> bool:
        """Fail with the first term that did not pass (``harness.pick.verdict``); True if one."""
        failed = first_failure(terms)
        if failed is not None:
            if not self.out.failure_reason:
                self.failed_term = failed.name
            self._fail(failed.reason, failed.message)
        return failed is not None

    def _object_speed(self) -> float:
        velocity = self.data.qvel[self.obj.dof_adr : self.obj.dof_adr + 3]
        return float(np.linalg.norm(velocity))

    def _object_in_tcp(self) -> np.ndarray:
        T_tcp = self.scene.T_world_body(self.handles.tcp_body)
        return (invert_T(T_tcp) @ np.append(self.data.xpos[self.obj.body_id], 1.0))[:3]

    # -- the validity phase (harness.pick.validity) ----------------------------------------------

    def _table_penetration(self, scene: Scene) -> TablePenetration:
        """What measures the table penetration (a hook: the schedule's lean run measures none)."""
        return TablePenetration(scene)

    def _track_penetration(self) -> None:
        depth = self.penetration.depth(self.data)
        if depth > self.out.table_penetration_m:
            self.out.table_penetration_m = depth

    def finish_step(self) -> bool:
        """One control step of the planned motion still playing; True when none is left."""
        if self.arm_plan is None and self.pending_segment is None and self.gripper_plan is None:
            return True
        self._control_step()
        self._track_penetration()
        if self.checker is not None:
            self._check_collisions()
        return False

    def hold_step(self, label: str) -> None:
        """One control step with every servo holding its setpoint."""
        if self.ctrl_log is not None:
            self.ctrl_log.append((self.substeps, self.data.ctrl.copy()))
        self.scene.step(self.substeps)
        self.out.sim_steps += self.substeps
        if self.recorder is not None:
            forces = self.scene.finger_forces(self.arm, self.object_name)
            self.recorder.record(self.time, label, forces)

    def object_speed(self) -> float:
        return self._object_speed()

    def event(self, text: str) -> None:
        self._event(text)

    def object_in_tcp(self) -> np.ndarray:
        return self._object_in_tcp()

    def object_pose_in_tcp(self) -> np.ndarray:
        """The object's pose in the TCP frame (4 x 4)."""
        T_tcp = self.scene.T_world_body(self.handles.tcp_body)
        return invert_T(T_tcp) @ self.scene.T_world_body(self.obj.body_id)

    @property
    def grasp_reference(self) -> np.ndarray | None:
        """The object's pose in the TCP frame when the closing ended (None if it never did)."""
        return self.out.T_tcp_object_closed
