"""One pick episode: scene reset, candidate selection, feasibility, plan, execution, verdict.

``run_episode(spec, scene_cache)`` never raises for episode-level problems: every outcome is one
flat row (``EpisodeResult.row``, the columns of ``harness.runs.store``) with ``success`` and a
``failure_reason`` from the taxonomy (ARCHITECTURE.md):

``filter_empty`` (no candidate at all), ``no_feasible_candidate`` (strict: none passed the
feasibility test), ``plan_failed`` (the executed motion could not be planned or timed),
``collision`` (strict), ``no_contact``, ``dropped``, ``lift_below_threshold``,
``velocity_invalid``, ``sim_unstable`` (NaN or MuJoCo warnings), ``timeout`` (the episode
length limit), ``error`` (an exception, with its message).

Timeline (the reference's, section 7 and quirks 6 and 7): reset and place; one reference step
(1/30 s) of physics; record the target's ``obj_init_trans`` (the lift reference); settle 20
steps; choose and test the grasp from the object pose at that moment; plan; 10 warm-up steps
with the robot holding still; execute. ``max_episode_length`` counts the execution's control
steps only, as the reference's loop does.

Randomness: one ``numpy.random.Generator`` seeded with ``spec.seed`` drives, in this fixed
order, the scene reset (robot root, object placement and orientation, home noise), the
candidate draw (``reference``: 20 weighted draws with replacement; ``strict`` with
``strict_sampling`` only), the post-grasp lift offset, and the planner's random restarts and
RRT samples -- same spec, same row. The reference uses two streams instead (Python ``random``
for the candidate draw, NumPy for the scene and the lift offset, quirk 22). The distributions
are the same; the numbers cannot be (different generators), so one stream in a documented order
is the simpler way to make each row reproducible from its seed.

The per-step record (``EpisodeResult.trace``) carries what a viewer needs: joint and object
trajectories, TCP poses, gripper width, finger forces, phases and events, every candidate with
its verdict, and the planned and executed TCP paths.

Scenes are cached per worker in ``scene_cache`` (any dict), keyed by (robot, objects, physics):
an episode on a cached scene only resets arrays.
"""

from __future__ import annotations

import json
import math
import time
import traceback
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from harness.config import PickConfig, TaskConfig
from harness.episode_ids import episode_id
from harness.episode_trace import EpisodeTrace, make_trace, planned_tcp
from harness.errors import EpisodeTimeoutError, HarnessError
from harness.failures import FailureReason
from harness.grasps import CandidateSelection, select_candidates
from harness.pick.execution_plan import PlanFailedError, plan_chosen
from harness.pick.executor import PickExecutor
from harness.pick.outcome import PickOutcome
from harness.pick.selection import walk_candidates
from harness.pick.semantics import Semantics
from harness.pick.targets import CandidatePoses, PickTargets
from harness.pick.validity import validity_columns, validity_enabled
from harness.planning.chain_timing import time_plan
from harness.planning.planner import PickPlanner
from harness.planning.plans import CandidateVerdict
from harness.planning.timing import TimingError
from harness.row import IDENTITY_COLUMNS, EpisodeRow, identity_columns
from harness.scene_cache import SceneBundle, get_scene, grasp_file_for
from harness.sim import ResetState, Scene
from harness.transforms import invert_T, quat_to_matrix
from harness.version import __version__

# The reference's episode timeline (simbox_dual_workflow.py, PhysX at 1/30 s per step): place,
# step once, build the skill (it records obj_init_trans), settle 20 steps, generate the first
# skill's commands (grasp selection and feasibility, from the object pose at that moment), step
# 10 warm-up steps, then run the control loop. A shorter settle leaves objects placed tilted
# (orientation_mode random) still moving when the grasp is chosen.
INIT_RECORD_TIME_S = 1 / 30
SETTLE_TIME_S = 20 / 30
WARMUP_TIME_S = 10 / 30


# --------------------------------------------------------------------------------------------
# Spec, result


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

    @property
    def success(self) -> bool:
        return bool(self.row.get("success"))

    @property
    def failure_reason(self) -> str:
        return str(self.row.get("failure_reason", ""))

    @property
    def model(self) -> mujoco.MjModel | None:
        return self.scene.model if self.scene is not None else None


# --------------------------------------------------------------------------------------------
# Row


def base_row(spec: EpisodeSpec) -> dict[str, Any]:
    """The identity and configuration columns of an episode's row."""
    pick = spec.task.pick

    def filt(value: Any) -> str:
        return "" if value is None else json.dumps(value.as_list())

    identity = identity_columns(spec)
    row = EpisodeRow(
        **{name: identity[name] for name in IDENTITY_COLUMNS},
        semantics=pick.semantics,
        test_mode=pick.test_mode,
        timing=pick.timing,
        filter_x_dir=filt(pick.filter_x_dir),
        filter_y_dir=filt(pick.filter_y_dir),
        filter_z_dir=filt(pick.filter_z_dir),
        approach_filter=filt(pick.approach_filter),
        facing_filter=filt(pick.facing_filter),
        direction_to_obj=pick.direction_to_obj or "",
        pre_grasp_offset=pick.pre_grasp_offset,
        harness_version=__version__,
        mujoco_version=mujoco.__version__,
    ).as_dict()
    row.update(identity)  # the param.* columns follow the fixed ones
    return row


# --------------------------------------------------------------------------------------------
# The episode


class _EpisodeStopError(Exception):
    """Ends an episode early with a failure reason (not an error)."""

    def __init__(self, reason: FailureReason, message: str) -> None:
        super().__init__(message)
        self.reason = reason
        self.message = message


def run_episode(spec: EpisodeSpec, scene_cache: dict[Any, Any] | None = None) -> EpisodeResult:
    """Run one episode; exceptions become ``error`` rows (see the module docstring)."""
    wall_start = time.perf_counter()
    row = base_row(spec)
    result = EpisodeResult(spec=spec, row=row)
    try:
        _run(spec, scene_cache, result)
    except _EpisodeStopError as stop:
        row["failure_reason"] = stop.reason
        row["error_message"] = stop.message
    except EpisodeTimeoutError as exc:  # harness.sim.budget: the run's limits, not an error
        row["failure_reason"] = "timeout"
        row["error_message"] = str(exc)
    except HarnessError as exc:
        row["failure_reason"] = "error"
        row["error_message"] = str(exc)
    except Exception as exc:  # any bug or library failure must not lose the episode
        row["failure_reason"] = "error"
        where = traceback.extract_tb(exc.__traceback__)[-1]
        row["error_message"] = (
            f"{type(exc).__name__}: {exc} (at {where.filename.rsplit('/', 1)[-1]}:{where.lineno})"
        )
    row["success"] = row["failure_reason"] == ""
    if validity_enabled(spec.task.pick) and not row["valid"] and not row["invalid_reason"]:
        row["invalid_reason"] = "not_run"  # ended before the execution's verdict
    row["wall_time_s"] = time.perf_counter() - wall_start
    return result


# --------------------------------------------------------------------------------------------
# The stages of ``_run``: reset, candidates, feasibility, execution plan, execute


@dataclass(frozen=True)
class _Setup:
    """The episode after its reset: the scene, the arm's planner, the episode's generator."""

    spec: EpisodeSpec
    result: EpisodeResult
    semantics: Semantics
    bundle: SceneBundle
    scene: Scene
    rng: np.random.Generator
    reset: ResetState
    planner: PickPlanner

    @property
    def task(self) -> TaskConfig:
        return self.spec.task

    @property
    def pick(self) -> PickConfig:
        return self.spec.task.pick

    @property
    def arm(self) -> str:
        return self.spec.task.arm

    @property
    def row(self) -> dict[str, Any]:
        return self.result.row


@dataclass
class _Planning:
    """What the planning stages share: the candidates, the clock, and the verdicts so far."""

    setup: _Setup
    selection: CandidateSelection
    poses: CandidatePoses
    T_world_object_start: np.ndarray
    t0: float  # the planning clock starts at the candidate selection
    ik_time_before: float = 0.0
    verdicts: list[CandidateVerdict] = field(default_factory=list)
    chosen: CandidateVerdict | None = None

    def finish_trace(
        self,
        outcome: PickOutcome | None,
        targets: PickTargets | None,
        planned: tuple[np.ndarray, np.ndarray, np.ndarray] | None,
    ) -> None:
        setup = self.setup
        setup.result.trace = make_trace(
            setup.scene, setup.arm, self.selection, self.poses.T_world_base, self.verdicts,
            self.chosen, outcome, targets, planned, self.T_world_object_start,
        )  # fmt: skip

    def record_plan_time(self) -> None:
        row = self.setup.row
        row["plan_time_s"] = time.perf_counter() - self.t0
        row["ik_time_s"] = self.setup.planner.ik.total_time - self.ik_time_before

    def stop(self, reason: FailureReason, message: str) -> _EpisodeStopError:
        """Record the planning time and the trace so far, and end the episode."""
        self.record_plan_time()
        self.finish_trace(None, None, None)
        return _EpisodeStopError(reason, message)


@dataclass(frozen=True)
class _Choice:
    """The candidate chosen by the feasibility stage, its base-frame pose, the start state."""

    chosen: CandidateVerdict
    T_base_grasp: np.ndarray
    q_now: np.ndarray


def _run(spec: EpisodeSpec, scene_cache: dict[Any, Any] | None, result: EpisodeResult) -> None:
    setup = _reset(spec, scene_cache, result)
    planning = _candidates(setup)
    choice = _feasibility(planning)
    targets, planned = _execution_plan(planning, choice)
    _execute(planning, targets, planned)


def _reset(spec: EpisodeSpec, scene_cache: dict[Any, Any] | None, result: EpisodeResult) -> _Setup:
    """1. Reset: placement, home + noise, obj_init_trans after one reference step, settle."""
    task = spec.task
    clock = time.perf_counter()
    bundle = get_scene(task, scene_cache)
    scene = bundle.scene
    result.scene = scene
    result.row["object_friction"] = scene.objects[task.target_object.name].asset.friction
    arm = task.arm
    gripper = scene.robot.arm(arm).gripper  # a clear error for an unknown arm
    result.row["grip_force_limit_n"] = gripper.force_limit
    result.row["gripper_variant"] = scene.robot.gripper_variant
    rng = np.random.default_rng(spec.seed)

    reset = scene.reset(task, rng, settle_time=SETTLE_TIME_S, init_record_time=INIT_RECORD_TIME_S)
    result.timings["settle_steps"] = float(reset.settle_steps)
    result.timings["setup_s"] = time.perf_counter() - clock
    if (reason := scene.unstable()) is not None:
        raise _EpisodeStopError("sim_unstable", f"while settling: {reason}")
    semantics = Semantics.from_pick(task.pick)
    planner = bundle.planner(arm)
    return _Setup(spec, result, semantics, bundle, scene, rng, reset, planner)


def _candidates(setup: _Setup) -> _Planning:
    """2. Candidates in the arm base frame, and the lift offset (drawn after them)."""
    task, pick, scene, arm, row, rng = (
        setup.task, setup.pick, setup.scene, setup.arm, setup.row, setup.rng
    )  # fmt: skip
    obj_name = task.target_object.name
    ee_poses = setup.bundle.poses(task, grasp_file_for(task, scene))
    T_world_base = scene.T_world_base(arm)
    T_world_obj = scene.T_world_object(obj_name)
    T_base_obj = invert_T(T_world_base) @ T_world_obj
    t0 = time.perf_counter()
    selection = select_candidates(
        ee_poses, scene.robot.convention, pick, T_base_obj, rng, setup.semantics.candidates
    )
    counts = selection.counts()
    row["n_total"] = counts["total"]
    row["n_passed_filter"] = counts["passed"]
    row["filter_outcome"] = selection.order.outcome
    lift_offset = float(rng.uniform(pick.post_grasp_offset_min, pick.post_grasp_offset_max))
    row["post_grasp_offset"] = lift_offset
    setup.result.trace = None
    fixed = None
    if pick.fixed_orientation is not None:
        fixed = quat_to_matrix(np.asarray(pick.fixed_orientation, dtype=float))
    poses = CandidatePoses(
        T_world_base, pick.pre_grasp_offset, scene.robot.convention.approach_index, lift_offset,
        fixed, setup.semantics.pregrasp_along_fixed_axis,
    )  # fmt: skip
    planning = _Planning(setup, selection, poses, T_world_obj, t0)
    if selection.order.outcome == "filter_empty":
        planning.finish_trace(None, None, None)
        raise _EpisodeStopError(
            "filter_empty", selection.order.note or "no pose passed the filters"
        )
    return planning


def _feasibility(planning: _Planning) -> _Choice:
    """3. Feasibility, candidate by candidate, in the planning world of the semantics."""
    setup = planning.setup
    task, pick, semantics, planner, row = (
        setup.task, setup.pick, setup.semantics, setup.planner, setup.row
    )  # fmt: skip
    world = semantics.planning_world(task.target_object.name)
    planner.sync(world)
    q_now = setup.scene.active_q(setup.arm)
    order = planning.selection.order
    T_base_candidates = planning.selection.T_base_ee_at(order.indices)
    test_carry = semantics.test_carry

    def test_targets(position: int) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """The poses a candidate is tested at. Reference: fixed_orientation is applied after the
        test (quirk 13); the lift only with ``test_carry``. Strict tests what it executes."""
        T_pre, T_grasp, T_lift = planning.poses.world(
            T_base_candidates[position], semantics.fixed_orientation_in_test
        )
        return T_pre, T_grasp, (T_lift if test_carry else None)

    planning.ik_time_before = planner.ik.total_time
    verdicts, chosen = walk_candidates(
        planner, pick, order.indices.tolist(), order.scores.tolist(),
        test_targets, q_now, setup.rng,
        return_to_pregrasp=pick.return_to_pregrasp and test_carry,
    )  # fmt: skip
    planning.verdicts, planning.chosen = verdicts, chosen
    row["n_tested"] = len(verdicts)
    row["n_feasible"] = len({v.pose_index for v in verdicts if v.feasible})
    if chosen is None:
        if not semantics.fall_back_to_last_tested or not verdicts:
            raise planning.stop(
                "no_feasible_candidate",
                f"none of the {len(verdicts)} candidates passed the {pick.test_mode} test"
                + (f"; last: {verdicts[-1].stage}: {verdicts[-1].detail}" if verdicts else ""),
            )
        chosen = verdicts[-1]  # the reference proceeds with the last candidate tested
        planning.chosen = chosen
    row["chosen_index"] = chosen.pose_index
    row["chosen_score"] = chosen.score
    T_base_chosen = T_base_candidates[chosen.position]
    axis = T_base_chosen[:3, planning.poses.approach_index]
    row["approach_angle_deg"] = math.degrees(math.acos(float(np.clip(-axis[2], -1.0, 1.0))))
    return _Choice(chosen, T_base_chosen, q_now)


def _execution_plan(
    planning: _Planning, choice: _Choice
) -> tuple[PickTargets, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """4. The executed plan, timed: its targets and the planned TCP path (for the trace)."""
    setup = planning.setup
    task, scene, arm, row = setup.task, setup.scene, setup.arm, setup.row
    try:
        plan = plan_chosen(
            setup.planner, setup.pick, setup.semantics, planning.poses,
            choice.chosen, choice.T_base_grasp, choice.q_now, setup.rng,
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
    planning: _Planning,
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
    scene.step(warmup_steps)
    result.timings["warmup_steps"] = float(warmup_steps)
    if (reason := scene.unstable()) is not None:
        raise _EpisodeStopError("sim_unstable", f"during the warm-up steps: {reason}")
    executor = PickExecutor(
        scene, setup.task, targets, setup.reset.object_init_position,
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
        raise _EpisodeStopError(outcome.failure_reason, outcome.message)
