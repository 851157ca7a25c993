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
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from harness import __version__
from harness.config import PickConfig, TaskConfig
from harness.episode_ids import episode_id
from harness.errors import HarnessError
from harness.grasps import (
    EEPoses,
    GraspSet,
    load_grasp_file,
    post_process,
    select_candidates,
)
from harness.pick.executor import FailureReason, PickExecutor, PickOutcome, PickTargets
from harness.planning.ik import WholeBodyIK
from harness.planning.motion import CandidateVerdict, ChainPlan, PickPlanner
from harness.planning.timing import (
    TimingError,
    TimingLimits,
    Trajectory,
    plan_timing,
    time_parameterize_toppra,
)
from harness.row import IDENTITY_COLUMNS, EpisodeRow, identity_columns
from harness.sim.scene import Scene, scene_key
from harness.transforms import invert_T, quat_to_matrix

# The reference's episode timeline (simbox_dual_workflow.py, PhysX at 1/30 s per step): place,
# step once, build the skill (it records obj_init_trans), settle 20 steps, generate the first
# skill's commands (grasp selection and feasibility, from the object pose at that moment), step
# 10 warm-up steps, then run the control loop. A shorter settle leaves objects placed tilted
# (orientation_mode random) still moving when the grasp is chosen.
INIT_RECORD_TIME_S = 1 / 30
SETTLE_TIME_S = 20 / 30
WARMUP_TIME_S = 10 / 30
TOPPRA_GRIDPOINTS = 30
# A forward test plans the carry (lift, return) too, under both semantics, so a candidate whose
# lift cannot be planned is skipped. The reference tests only the pre-grasp and the grasp, and
# would execute that candidate and fail (is_feasible). False reproduces that: the carry is then
# planned for the chosen candidate alone. Kept True for now: on the canonical cube the
# reference rule fails 3 of 10 Split ALOHA right-arm seeds on lift poses out of the Piper's
# reach, which the calibrated end-to-end test does not allow (docs/semantics.md).
FORWARD_TEST_PLANS_CARRY = True
PLAN_RETRIES = 2  # extra attempts for a randomised (RRT / restart) plan failure
# The Cartesian segments near the object (approach, lift, retreat) run at this fraction of the
# joint limits: time-optimal at full limits, the small arms' soft servos (kp 80, wrists 10)
# overshoot the grasp by up to a centimetre.
CARTESIAN_SPEED_SCALE = 0.5
# Strict semantics plan the robot this far (m) from the table, so that servo tracking lag (the
# small arms' wrists have kp 10) does not dip a finger into it during execution.
STRICT_TABLE_CLEARANCE = 0.005

# Candidate verdict labels (also used by the Rerun recorder's colours).
REJECTED, PASSED, INFEASIBLE, FEASIBLE, CHOSEN = (
    "rejected",
    "passed",
    "infeasible",
    "feasible",
    "chosen",
)
MAX_TRACE_CANDIDATES = 600


# --------------------------------------------------------------------------------------------
# Spec, trace, result


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
class EpisodeTrace:
    """Per-servo-chunk (~10 ms) arrays of an episode for viewers (times in s of simulated time)."""

    time: np.ndarray  # (T,)
    qpos: np.ndarray  # (T, nq) full MuJoCo qpos (replay with mj_kinematics)
    mocap_pos: np.ndarray  # (nmocap, 3) robot root pose (mocap) during the episode
    mocap_quat: np.ndarray  # (nmocap, 4)
    joint_names: tuple[str, ...]  # the arm's active joints (lift first)
    q: np.ndarray  # (T, n) those joints
    tcp_pose: np.ndarray  # (T, 7) world position + wxyz
    ee_pose: np.ndarray  # (T, 7)
    gripper_width: np.ndarray  # (T,) m
    finger_forces: np.ndarray  # (T, 2) N, left / right finger on the target object
    object_pose: np.ndarray  # (T, 7)
    phase: np.ndarray  # (T,) str
    events: list[tuple[float, str]]
    candidate_index: np.ndarray  # (M,) pose index into the 2N EE poses
    candidate_T_world_ee: np.ndarray  # (M, 4, 4)
    candidate_score: np.ndarray  # (M,)
    candidate_status: np.ndarray  # (M,) str: rejected/passed/infeasible/feasible/chosen
    candidate_detail: list[str]  # (M,) why infeasible ("" otherwise)
    planned_time: np.ndarray  # (K,) s from the start of execution
    planned_tcp: np.ndarray  # (K, 3) world TCP points of the planned motion
    planned_segment: np.ndarray  # (K,) str
    T_world_object_start: np.ndarray  # (4, 4) target object at selection time
    T_world_grasp: np.ndarray | None = None  # planned EE pose at the grasp
    T_world_pregrasp: np.ndarray | None = None
    T_world_lift: np.ndarray | None = None


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
# Cached per-scene state


@dataclass
class SceneBundle:
    """A scene with its per-arm IK solvers and planners and the grasp poses it has used."""

    scene: Scene
    iks: dict[str, WholeBodyIK] = field(default_factory=dict)
    planners: dict[str, PickPlanner] = field(default_factory=dict)
    grasp_sets: dict[str, GraspSet] = field(default_factory=dict)
    ee_poses: dict[tuple[Any, ...], EEPoses] = field(default_factory=dict)

    def planner(self, arm: str) -> PickPlanner:
        if arm not in self.planners:
            robot = self.scene.robot
            handles = self.scene.arms[arm]
            limits = {j: robot.joint_limits(j) for j in handles.active_names}
            ik = WholeBodyIK(
                robot.urdf_path,
                handles.active_names,
                robot.arm(arm).ee_frame,
                robot.lift_joint,
                limits,
            )
            self.iks[arm] = ik
            self.planners[arm] = PickPlanner(self.scene, arm, ik)
        return self.planners[arm]

    def poses(self, task: TaskConfig, grasp_path: str) -> EEPoses:
        pick = task.pick
        key = (grasp_path, pick.grasp_scale, pick.tcp_offset, pick.constraints)
        if key not in self.ee_poses:
            if grasp_path not in self.grasp_sets:
                self.grasp_sets[grasp_path] = load_grasp_file(grasp_path)
            self.ee_poses[key] = post_process(
                self.grasp_sets[grasp_path],
                self.scene.robot.convention,
                pick.grasp_scale,
                pick.tcp_offset,
                pick.constraints,
            )
        return self.ee_poses[key]


def get_scene(task: TaskConfig, scene_cache: dict[Any, Any] | None) -> SceneBundle:
    """The scene for ``task``, built once per (robot, objects, physics) in ``scene_cache``."""
    key = scene_key(task)
    if scene_cache is not None and key in scene_cache:
        return scene_cache[key]
    scene = Scene.build(task.robot, task.objects, task.physics, task.base_dir())
    bundle = SceneBundle(scene)
    if scene_cache is not None:
        scene_cache[key] = bundle
    return bundle


def grasp_file_for(task: TaskConfig, scene: Scene) -> str:
    """The target object's grasp file: ``grasps`` if given, else the naming rule."""
    from harness.objects.assets import find_grasp_file

    obj = task.target_object
    asset = scene.objects[obj.name].asset
    if obj.grasps:
        path = asset.grasp_path
    elif task.pick.npy_name != "Aligned_grasp_sparse.npy":
        path = find_grasp_file(asset.path, task.pick.npy_name)
    else:
        path = asset.grasp_path
    if path is None:
        raise HarnessError(
            f"object {obj.name!r} ({asset.path}) has no grasp file "
            f"({task.pick.npy_name} or <mesh>_grasps.npy or grasps.npy next to the mesh)"
        )
    return str(path)


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
    row["wall_time_s"] = time.perf_counter() - wall_start
    return result


def _run(spec: EpisodeSpec, scene_cache: dict[Any, Any] | None, result: EpisodeResult) -> None:
    task = spec.task
    pick = task.pick
    row = result.row
    clock = time.perf_counter()
    bundle = get_scene(task, scene_cache)
    scene = bundle.scene
    result.scene = scene
    arm = task.arm
    scene.robot.arm(arm)  # a clear error for an unknown arm
    rng = np.random.default_rng(spec.seed)

    # 1. Reset: placement, home + noise, obj_init_trans after one reference step, settle.
    reset = scene.reset(task, rng, settle_time=SETTLE_TIME_S, init_record_time=INIT_RECORD_TIME_S)
    result.timings["settle_steps"] = float(reset.settle_steps)
    result.timings["setup_s"] = time.perf_counter() - clock
    if (reason := scene.unstable()) is not None:
        raise _EpisodeStopError("sim_unstable", f"while settling: {reason}")
    planner = bundle.planner(arm)
    ik = planner.ik
    obj_name = task.target_object.name

    # 2. Candidates in the arm base frame.
    poses = bundle.poses(task, grasp_file_for(task, scene))
    T_world_base = scene.T_world_base(arm)
    T_world_obj = scene.T_world_object(obj_name)
    T_base_obj = invert_T(T_world_base) @ T_world_obj
    t0 = time.perf_counter()
    selection = select_candidates(poses, scene.robot.convention, pick, T_base_obj, rng)
    counts = selection.counts()
    row["n_total"] = counts["total"]
    row["n_passed_filter"] = counts["passed"]
    row["filter_outcome"] = selection.order.outcome
    lift_offset = float(rng.uniform(pick.post_grasp_offset_min, pick.post_grasp_offset_max))
    row["post_grasp_offset"] = lift_offset
    trace_parts: dict[str, Any] = {"T_world_object_start": T_world_obj}
    result.trace = None

    def finish_trace(
        outcome: PickOutcome | None,
        verdicts: list[CandidateVerdict],
        chosen: CandidateVerdict | None,
        targets: PickTargets | None,
        planned: tuple[np.ndarray, np.ndarray, np.ndarray] | None,
    ) -> None:
        result.trace = _make_trace(
            scene,
            arm,
            selection,
            T_world_base,
            verdicts,
            chosen,
            outcome,
            targets,
            planned,
            trace_parts,
        )

    if selection.order.outcome == "filter_empty":
        finish_trace(None, [], None, None, None)
        raise _EpisodeStopError(
            "filter_empty", selection.order.note or "no pose passed the filters"
        )

    # 3. Feasibility, candidate by candidate.
    # The planning world holds what the robot physically collides with: the table when robot-
    # table contact is on (and always under strict semantics; the reference's planning ignores
    # the table even where it is physical, quirk 21, planning fingers into it), and the target
    # object under both semantics (the fingers may touch it on the approach; the reference
    # removes it while planning the pre-grasp and the grasp, section 6 step 2, which lets a
    # transport sweep through it and knock it over). Other objects are in it unless the pick's
    # ignore_substring names them (the reference planner's ignore list); strict ignores nothing.
    strict = pick.semantics == "strict"
    planner.sync(
        obj_name,
        check_table=task.physics.table_contact or strict,
        check_target=True,
        table_clearance=STRICT_TABLE_CLEARANCE if strict else 0.0,
        ignore_substring=() if strict else tuple(pick.ignore_substring),
        hold_lift=True,  # the reference plans the arm alone, the lift held at its home
    )
    q_now = scene.active_q(arm)
    approach = scene.robot.convention.approach_index
    order = selection.order
    T_base_candidates = selection.T_base_ee_at(order.indices)
    fixed = None
    if pick.fixed_orientation is not None:
        fixed = quat_to_matrix(np.asarray(pick.fixed_orientation, dtype=float))

    def targets_for(T_base_grasp: np.ndarray, apply_fixed: bool) -> tuple[np.ndarray, ...]:
        base = command_targets(
            T_base_grasp,
            pick.pre_grasp_offset,
            approach,
            lift_offset,
            fixed if apply_fixed else None,
            pick.semantics,
        )
        return tuple(T_world_base @ T if T is not None else None for T in base)

    test_carry = strict or FORWARD_TEST_PLANS_CARRY

    def test_targets(position: int) -> tuple[np.ndarray, ...]:
        """The poses a candidate is tested at. Reference: fixed_orientation is applied after the
        test (quirk 13); the lift only with ``test_carry``. Strict tests what it executes."""
        T_pre, T_grasp, T_lift = targets_for(T_base_candidates[position], strict)
        return T_pre, T_grasp, (T_lift if test_carry else None)

    ik_time_before = ik.total_time
    verdicts, chosen = _test_candidates(
        planner, pick, order.indices.tolist(), order.scores.tolist(),
        test_targets, q_now, rng,
        return_to_pregrasp=pick.return_to_pregrasp and test_carry,
    )  # fmt: skip
    row["n_tested"] = len(verdicts)
    row["n_feasible"] = len({v.pose_index for v in verdicts if v.feasible})

    def stop_planning(reason: FailureReason, message: str) -> _EpisodeStopError:
        """Record the planning time and the trace so far, and end the episode."""
        row["plan_time_s"] = time.perf_counter() - t0
        row["ik_time_s"] = ik.total_time - ik_time_before
        finish_trace(None, verdicts, chosen, None, None)
        return _EpisodeStopError(reason, message)

    if chosen is None:
        if strict or not verdicts:
            raise stop_planning(
                "no_feasible_candidate",
                f"none of the {len(verdicts)} candidates passed the {pick.test_mode} test"
                + (f"; last: {verdicts[-1].stage}: {verdicts[-1].detail}" if verdicts else ""),
            )
        chosen = verdicts[-1]  # the reference proceeds with the last candidate tested
    row["chosen_index"] = chosen.pose_index
    row["chosen_score"] = chosen.score
    T_base_chosen = T_base_candidates[chosen.position]
    axis = T_base_chosen[:3, approach]
    row["approach_angle_deg"] = math.degrees(math.acos(float(np.clip(-axis[2], -1.0, 1.0))))

    # 4. The executed plan: reuse a feasible forward plan, else plan now (fixed_orientation is
    #    applied after the test in the reference, so the executed motion is re-planned).
    T_pre, T_grasp, T_lift = targets_for(T_base_chosen, True)
    plan: ChainPlan | None = chosen.plan if (fixed is None or strict) else None
    attempts = 0
    failure = chosen
    if plan is not None and not test_carry and (T_lift is not None or pick.return_to_pregrasp):
        # A forward test without the carry: the chosen plan ends at the grasp; plan it now.
        plan, stage, why = planner.plan_carry(plan, T_lift, pick.return_to_pregrasp)
        if plan is None:
            raise stop_planning("plan_failed", f"{stage}: {why}")
    while plan is None and attempts <= PLAN_RETRIES:
        attempts += 1
        tested = chosen.ik_pregrasp
        failure = planner.plan_chain(
            chosen.position, chosen.pose_index, chosen.score, q_now, T_pre, T_grasp, T_lift,
            pick.return_to_pregrasp, rng,
            pregrasp_seed=tested.q if tested is not None and tested.success else None,
        )  # fmt: skip
        plan = failure.plan
        if failure.stage not in ("transport", "ik_pregrasp"):
            break  # deterministic failures do not change on a retry
    if plan is None:
        raise stop_planning("plan_failed", f"{failure.stage}: {failure.detail}")
    try:
        segments = time_plan(plan, scene, arm, task)
    except TimingError as exc:
        raise stop_planning("plan_failed", f"timing: {exc}") from None
    row["plan_time_s"] = time.perf_counter() - t0
    row["ik_time_s"] = ik.total_time - ik_time_before
    row["traj_duration_s"] = sum(s.duration for s in segments.values())
    targets = PickTargets(plan.T_world_pregrasp, plan.T_world_grasp, plan.T_world_lift, segments)
    planned = _planned_tcp(ik, scene, arm, segments, task.control_dt)

    # 5. The reference's 10 warm-up steps (robot holding its home), then execute and judge.
    result.timings["plan_s"] = row["plan_time_s"]
    clock = time.perf_counter()
    warmup_steps = max(1, round(WARMUP_TIME_S / scene.model.opt.timestep))
    warmup_ctrl = scene.data.ctrl.copy()
    scene.step(warmup_steps)
    result.timings["warmup_steps"] = float(warmup_steps)
    if (reason := scene.unstable()) is not None:
        raise _EpisodeStopError("sim_unstable", f"during the warm-up steps: {reason}")
    executor = PickExecutor(
        scene, task, targets, reset.object_init_position, lift_offset, planner.checker,
        record=True, log_ctrl=spec.log_ctrl,
    )  # fmt: skip
    outcome = executor.run()
    result.timings["sim_s"] = time.perf_counter() - clock
    if executor.ctrl_log is not None:
        result.ctrl_log = [(warmup_steps, warmup_ctrl), *executor.ctrl_log]
    finish_trace(outcome, verdicts, chosen, targets, planned)
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
    if outcome.failure_reason:
        raise _EpisodeStopError(outcome.failure_reason, outcome.message)


def command_targets(
    T_base_grasp: np.ndarray,
    pre_grasp_offset: float,
    approach_index: int,
    lift_offset: float,
    fixed_rotation: np.ndarray | None = None,
    semantics: str = "reference",
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Arm-base-frame pre-grasp, grasp and lift poses of one candidate (section 6).

    The pre-grasp is the grasp moved ``pre_grasp_offset`` back along EE column
    ``approach_index`` (the reference picks column 0 when "r5a" is in the planner file name and
    column 2 otherwise, quirk 14: the same column as ``ee_axis`` on all three robots); the lift
    is the grasp moved ``lift_offset`` up along base z, in the grasp's orientation (quirk 12).
    ``fixed_rotation`` replaces the orientation of all three. Under ``reference`` semantics the
    positions stay those of the candidate (the reference overwrites only the quaternions, after
    computing the pre-grasp from the candidate's own approach axis, quirk 13); under
    ``strict`` the pre-grasp backs off along the fixed orientation's approach axis, so the
    approach is straight along the executed hand axis.
    """
    T_grasp = np.array(T_base_grasp, dtype=float)
    if fixed_rotation is not None and semantics == "strict":
        T_grasp[:3, :3] = fixed_rotation
    T_pre = T_grasp.copy()
    T_pre[:3, 3] -= pre_grasp_offset * T_grasp[:3, approach_index]
    if fixed_rotation is not None:
        T_grasp[:3, :3] = fixed_rotation
        T_pre[:3, :3] = fixed_rotation
    T_lift = None
    if lift_offset != 0.0:
        T_lift = T_grasp.copy()
        T_lift[2, 3] += lift_offset
    return T_pre, T_grasp, T_lift


def _test_candidates(
    planner: PickPlanner,
    pick: PickConfig,
    indices: list[int],
    scores: list[float],
    targets_of: Callable[[int], tuple[np.ndarray, np.ndarray, np.ndarray | None]],
    q_now: np.ndarray,
    rng: np.random.Generator,
    return_to_pregrasp: bool = False,
) -> tuple[list[CandidateVerdict], CandidateVerdict | None]:
    """Walk the ordered candidates until one passes ``pick.test_mode``; (verdicts, chosen).

    ``targets_of(position)`` gives the world pre-grasp, grasp and lift poses of a candidate
    (the lift None when the test plans none); a ``forward`` test plans the return to the
    pre-grasp only with ``return_to_pregrasp``.
    A duplicate (the reference draws with replacement) reuses the first answer: the reference
    re-tests it and gets the same one.
    """
    tested: dict[int, CandidateVerdict] = {}
    verdicts: list[CandidateVerdict] = []
    for position, pose_index in enumerate(indices):
        score = float(scores[position])
        if pose_index in tested:
            previous = tested[pose_index]
            verdict = CandidateVerdict(
                position, pose_index, score, previous.feasible, previous.stage, previous.detail,
                previous.ik_pregrasp, previous.ik_grasp, previous.plan, 0.0,
            )  # fmt: skip
        else:
            T_pre, T_grasp, T_lift = targets_of(position)
            if pick.test_mode == "ik":
                verdict = planner.test_ik(
                    position, pose_index, score, q_now, T_pre, T_grasp,
                    pick.pre_grasp_offset > 0, rng,
                )  # fmt: skip
            else:
                verdict = planner.plan_chain(
                    position, pose_index, score, q_now, T_pre, T_grasp, T_lift,
                    return_to_pregrasp, rng,
                )  # fmt: skip
            tested[pose_index] = verdict
        verdicts.append(verdict)
        if verdict.feasible:
            return verdicts, verdict
    return verdicts, None


def time_plan(plan: ChainPlan, scene: Scene, arm: str, task: TaskConfig) -> dict[str, Trajectory]:
    """Timed segments of a chain plan. ``pick.timing`` times the joint-space transport; the
    Cartesian approach, lift and retreat always use TOPP-RA through their dense IK waypoints
    (offline Ruckig would stop at every waypoint), at ``CARTESIAN_SPEED_SCALE``."""
    robot = scene.robot
    names = scene.arms[arm].active_names
    limits = TimingLimits(
        robot.velocity_limits(names),
        robot.acceleration_limits(names),
        robot.jerk_limits(names),
        task.pick.speed_scale,
    )
    segments: dict[str, Trajectory] = {
        "transport": plan_timing(
            plan.transport, limits, task.pick.timing, names, "transport", TOPPRA_GRIDPOINTS
        )
    }

    def cartesian(waypoints: np.ndarray, label: str) -> Trajectory:
        return time_parameterize_toppra(
            waypoints,
            limits.velocity,
            limits.acceleration,
            limits.speed_scale * CARTESIAN_SPEED_SCALE,
            gridpoints=TOPPRA_GRIDPOINTS,
            joint_names=names,
            label=label,
        )

    segments["approach"] = cartesian(plan.approach, "approach")
    if plan.lift is not None:
        segments["lift"] = cartesian(plan.lift, "lift")
    if plan.retreat is not None:
        segments["retreat"] = cartesian(plan.retreat, "retreat")
    return segments


def _planned_tcp(
    ik: WholeBodyIK, scene: Scene, arm: str, segments: dict[str, Trajectory], dt: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """TCP points of the planned segments (played back to back) every ``dt`` seconds."""
    tcp_frame = scene.robot.arm(arm).tcp_frame
    times, points, labels = [], [], []
    offset = 0.0
    for label, trajectory in segments.items():
        ts = trajectory.time_grid(dt)
        qs, _, _ = trajectory.sample_many(ts)
        for t, q in zip(ts, qs, strict=True):
            times.append(offset + t)
            points.append(ik.fk(q, tcp_frame)[:3, 3])
            labels.append(label)
        offset += trajectory.duration
    return np.asarray(times), np.asarray(points).reshape(-1, 3), np.asarray(labels)


def _make_trace(
    scene: Scene,
    arm: str,
    selection: Any,
    T_world_base: np.ndarray,
    verdicts: list[CandidateVerdict],
    chosen: CandidateVerdict | None,
    outcome: PickOutcome | None,
    targets: PickTargets | None,
    planned: tuple[np.ndarray, np.ndarray, np.ndarray] | None,
    parts: dict[str, Any],
) -> EpisodeTrace:
    d = scene.data
    # Candidates: every tested pose, then passing and rejected poses, each up to a cap.
    status: dict[int, str] = {}
    detail: dict[int, str] = {}
    for v in verdicts:
        status[v.pose_index] = FEASIBLE if v.feasible else INFEASIBLE
        detail[v.pose_index] = "" if v.feasible else f"{v.stage}: {v.detail}"
    if chosen is not None:
        status[chosen.pose_index] = CHOSEN
    passing = selection.filter_result.passing_indices
    for index in passing[:MAX_TRACE_CANDIDATES].tolist():
        status.setdefault(int(index), PASSED)
    # What the filters threw away, evenly thinned to the same cap so the viewer stays light.
    rejected = np.flatnonzero(~selection.filter_result.combined)
    if len(rejected) > MAX_TRACE_CANDIDATES:
        rejected = rejected[np.linspace(0, len(rejected) - 1, MAX_TRACE_CANDIDATES).astype(int)]
    for index in rejected.tolist():
        status.setdefault(int(index), REJECTED)
    indices = np.array(sorted(status), dtype=np.int64)
    T_world_ee = (
        T_world_base @ selection.T_base_ee_at(indices) if len(indices) else np.zeros((0, 4, 4))
    )
    handles = scene.arms[arm]
    empty7 = np.zeros((0, 7))
    ex = outcome.trace if outcome is not None else None
    times, points, labels = (
        planned if planned is not None else (np.zeros(0), np.zeros((0, 3)), np.zeros(0, dtype=str))
    )
    return EpisodeTrace(
        time=ex.time if ex else np.zeros(0),
        qpos=ex.qpos if ex else np.zeros((0, scene.model.nq)),
        mocap_pos=d.mocap_pos.copy(),
        mocap_quat=d.mocap_quat.copy(),
        joint_names=handles.active_names,
        q=ex.q_active if ex else np.zeros((0, len(handles.active_names))),
        tcp_pose=ex.tcp_pose if ex else empty7,
        ee_pose=ex.ee_pose if ex else empty7,
        gripper_width=ex.gripper_width if ex else np.zeros(0),
        finger_forces=ex.finger_forces if ex else np.zeros((0, 2)),
        object_pose=ex.object_pose if ex else empty7,
        phase=ex.phase if ex else np.zeros(0, dtype=str),
        events=ex.events if ex else [],
        candidate_index=indices,
        candidate_T_world_ee=T_world_ee,
        candidate_score=selection.ee_poses.scores[indices] if len(indices) else np.zeros(0),
        candidate_status=np.array([status[int(i)] for i in indices], dtype=str),
        candidate_detail=[detail.get(int(i), "") for i in indices],
        planned_time=times,
        planned_tcp=points,
        planned_segment=labels,
        T_world_object_start=parts["T_world_object_start"],
        T_world_grasp=targets.T_world_grasp if targets else None,
        T_world_pregrasp=targets.T_world_pregrasp if targets else None,
        T_world_lift=targets.T_world_lift if targets else None,
    )
