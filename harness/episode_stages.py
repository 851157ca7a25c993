"""The stages of one episode: reset, candidates, feasibility, execution plan, execution.

``harness.episode.run_episode`` runs them in this order. Each stage first asks the seed's
evaluation (``harness.candidate_cache.SeedEvaluation``) what it already knows -- the reset's
facts, a candidate's verdict, a chosen candidate's executed outcome -- and computes only what is
missing. Without a shared cache the evaluation starts empty and every stage computes, as an
unshared episode always did.

The scene must hold the seed's untouched reset whenever something is computed (a feasibility
test reads the object poses; an execution steps from them). ``Setup.ensure_fresh`` re-runs the
reset (deterministic in the seed's scene stream) unless the scene's ``reset_mark`` says it
already holds exactly that state.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from harness.candidate_cache import WALL_TIME_COLUMNS, ExecutedOutcome, ResetFacts, SeedEvaluation
from harness.config import PickConfig, TaskConfig
from harness.engines import ExecutionJob, engine_for
from harness.episode_spec import EpisodeResult, EpisodeSpec
from harness.episode_streams import EpisodeStreams
from harness.episode_trace import make_trace, planned_tcp
from harness.failures import FailureReason
from harness.grasps import CandidateSelection, select_candidates
from harness.pick.execution_plan import PlanFailedError, plan_chosen
from harness.pick.outcome import PickOutcome
from harness.pick.selection import (
    candidate_failures_json,
    none_feasible_message,
    walk_candidates,
)
from harness.pick.semantics import Semantics
from harness.pick.targets import CandidatePoses, PickTargets
from harness.pick.validity import validity_columns
from harness.planning.chain_timing import time_plan
from harness.planning.planner import PickPlanner
from harness.planning.plans import CandidateVerdict
from harness.planning.timing import TimingError
from harness.scene_cache import SceneBundle, get_scene, grasp_file_for
from harness.sim import Scene
from harness.transforms import invert_T, quat_to_matrix

# The reference's episode timeline (simbox_dual_workflow.py, PhysX at 1/30 s per step): place,
# step once, build the skill (it records obj_init_trans), settle 20 steps, generate the first
# skill's commands (grasp selection and feasibility, from the object pose at that moment), step
# 10 warm-up steps, then run the control loop. A shorter settle leaves objects placed tilted
# (orientation_mode random) still moving when the grasp is chosen.
INIT_RECORD_TIME_S = 1 / 30
SETTLE_TIME_S = 20 / 30
WARMUP_TIME_S = 10 / 30


class EpisodeStopError(Exception):
    """Ends an episode early with a failure reason (not an error)."""

    def __init__(self, reason: FailureReason, message: str) -> None:
        super().__init__(message)
        self.reason = reason
        self.message = message


def _scene_state(scene: Scene) -> tuple[np.ndarray, ...]:
    d = scene.data
    return (d.qpos.copy(), d.qvel.copy(), d.ctrl.copy(), np.array([d.time]))


@dataclass
class Setup:
    """The episode's scene, planner, random streams and the seed's evaluation."""

    spec: EpisodeSpec
    result: EpisodeResult
    semantics: Semantics
    bundle: SceneBundle
    streams: EpisodeStreams
    evaluation: SeedEvaluation
    key: Any  # the evaluation's key: which reset the scene must hold
    planner: PickPlanner
    used_shared: bool = False  # answered partly from evaluations of earlier episodes
    synced: bool = False  # the planner holds this episode's planning world

    @property
    def scene(self) -> Scene:
        return self.bundle.scene

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

    @property
    def facts(self) -> ResetFacts:
        assert self.evaluation.reset is not None, "the reset runs before anything reads it"
        return self.evaluation.reset

    def ensure_fresh(self, force: bool = False) -> None:
        """Make the scene hold this seed's reset, running it unless it is already there."""
        if not force and self._holds_reset():
            return
        scene, task = self.scene, self.task
        self.evaluation.stats.resets += 1
        reset = scene.reset(
            task, self.streams.scene(), settle_time=SETTLE_TIME_S,
            init_record_time=INIT_RECORD_TIME_S,
        )  # fmt: skip
        if self.evaluation.reset is None:
            self.evaluation.reset = ResetFacts(
                T_world_base=scene.T_world_base(self.arm),
                T_world_object=scene.T_world_object(task.target_object.name),
                object_init_position=reset.object_init_position,
                q_now=scene.active_q(self.arm),
                settle_steps=reset.settle_steps,
                unstable=scene.unstable(),
            )
        self.bundle.reset_mark = (self.key, _scene_state(scene))
        self.synced = False

    def _holds_reset(self) -> bool:
        mark = self.bundle.reset_mark
        if mark is None or mark[0] != self.key:
            return False
        now = _scene_state(self.scene)
        return all(np.array_equal(a, b) for a, b in zip(mark[1], now, strict=True))

    def ensure_synced(self) -> None:
        """A fresh scene and the planner synced to this episode's planning world."""
        self.ensure_fresh()
        if not self.synced:
            self.planner.sync(self.semantics.planning_world(self.task.target_object.name))
            self.synced = True

    def mark_stepped(self) -> None:
        """The scene is about to leave the reset state."""
        self.bundle.reset_mark = None


@dataclass
class Planning:
    """What the planning stages share: the candidates, the clock, and the verdicts so far."""

    setup: Setup
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

    def stop(self, reason: FailureReason, message: str) -> EpisodeStopError:
        """Record the planning time and the trace so far, and end the episode."""
        self.record_plan_time()
        self.finish_trace(None, None, None)
        return EpisodeStopError(reason, message)


@dataclass(frozen=True)
class Choice:
    """The candidate chosen by the feasibility stage and its base-frame pose."""

    chosen: CandidateVerdict
    T_base_grasp: np.ndarray


def reset(
    spec: EpisodeSpec,
    scene_cache: dict[Any, Any] | None,
    result: EpisodeResult,
    evaluation: SeedEvaluation,
    key: Any,
) -> Setup:
    """1. Reset: placement, home + noise, obj_init_trans after one reference step, settle."""
    task = spec.task
    clock = time.perf_counter()
    bundle = get_scene(task, scene_cache)
    scene = bundle.scene
    result.scene = scene
    result.row["object_friction"] = scene.objects[task.target_object.name].asset.friction
    gripper = scene.robot.arm(task.arm).gripper  # a clear error for an unknown arm
    result.row["grip_force_limit_n"] = gripper.force_limit
    result.row["gripper_variant"] = scene.robot.gripper_variant
    semantics = Semantics.from_pick(task.pick)
    planner = bundle.planner(task.arm)
    streams = EpisodeStreams(spec.seed)
    setup = Setup(spec, result, semantics, bundle, streams, evaluation, key, planner)
    if evaluation.reset is None:
        setup.ensure_fresh(force=True)
    else:
        setup.used_shared = True
        evaluation.stats.reset_hits += 1
    facts = setup.facts
    result.timings["settle_steps"] = float(facts.settle_steps)
    result.timings["setup_s"] = time.perf_counter() - clock
    if facts.unstable is not None:
        raise EpisodeStopError("sim_unstable", f"while settling: {facts.unstable}")
    return setup


def candidates(setup: Setup) -> Planning:
    """2. Candidates in the arm base frame, and the lift offset (its own stream)."""
    task, pick, scene, row, facts = setup.task, setup.pick, setup.scene, setup.row, setup.facts
    ee_poses = setup.bundle.poses(task, grasp_file_for(task, scene))
    T_base_obj = invert_T(facts.T_world_base) @ facts.T_world_object
    t0 = time.perf_counter()
    selection = select_candidates(
        ee_poses, scene.robot.convention, pick, T_base_obj, setup.streams.candidates(),
        setup.semantics.candidates,
    )  # fmt: skip
    counts = selection.counts()
    row["n_total"] = counts["total"]
    row["n_passed_filter"] = counts["passed"]
    row["filter_outcome"] = selection.order.outcome
    lift_rng = setup.streams.lift()
    lift_offset = float(lift_rng.uniform(pick.post_grasp_offset_min, pick.post_grasp_offset_max))
    row["post_grasp_offset"] = lift_offset
    setup.result.trace = None
    fixed = None
    if pick.fixed_orientation is not None:
        fixed = quat_to_matrix(np.asarray(pick.fixed_orientation, dtype=float))
    poses = CandidatePoses(
        facts.T_world_base, pick.pre_grasp_offset, scene.robot.convention.approach_index,
        lift_offset, fixed, setup.semantics.pregrasp_along_fixed_axis,
    )  # fmt: skip
    planning = Planning(setup, selection, poses, facts.T_world_object, t0)
    if selection.order.outcome == "filter_empty":
        planning.finish_trace(None, None, None)
        raise EpisodeStopError("filter_empty", selection.order.note or "no pose passed the filters")
    return planning


def feasibility(planning: Planning) -> Choice:
    """3. Feasibility, candidate by candidate, in the planning world of the semantics."""
    setup = planning.setup
    pick, semantics, planner, row = setup.pick, setup.semantics, setup.planner, setup.row
    q_now = setup.facts.q_now
    order = planning.selection.order
    T_base_candidates = planning.selection.T_base_ee_at(order.indices)
    test_carry = semantics.test_carry
    return_to_pregrasp = pick.return_to_pregrasp and test_carry

    def test(position: int, pose_index: int, score: float) -> CandidateVerdict:
        """Test one candidate at the poses its semantics test. Reference: fixed_orientation is
        applied after the test (quirk 13); the lift only with ``test_carry``. Strict tests what
        it executes."""
        setup.ensure_synced()
        T_pre, T_grasp, T_lift = planning.poses.world(
            T_base_candidates[position], semantics.fixed_orientation_in_test
        )
        rng = setup.streams.planner(pose_index)
        if pick.test_mode == "ik":
            verdict = planner.test_ik(
                position, pose_index, score, q_now, T_pre, T_grasp, pick.pre_grasp_offset > 0, rng
            )
        else:
            verdict = planner.plan_chain(
                position, pose_index, score, q_now, T_pre, T_grasp,
                T_lift if test_carry else None, return_to_pregrasp, rng,
            )  # fmt: skip
        verdict.T_world_pregrasp, verdict.T_world_grasp = T_pre, T_grasp
        return verdict

    planning.ik_time_before = planner.ik.total_time
    known = setup.evaluation.verdicts
    known_before = set(known)
    verdicts, chosen = walk_candidates(order.indices.tolist(), order.scores.tolist(), test, known)
    reused = {v.pose_index for v in verdicts} & known_before
    stats = setup.evaluation.stats
    stats.verdict_hits += len(reused)
    stats.verdicts += len(known) - len(known_before)
    if reused:
        setup.used_shared = True
    planning.verdicts, planning.chosen = verdicts, chosen
    row["n_tested"] = len(verdicts)
    row["n_feasible"] = len({v.pose_index for v in verdicts if v.feasible})
    row["candidate_failures"] = candidate_failures_json(verdicts)
    if chosen is None:
        if not semantics.fall_back_to_last_tested or not verdicts:
            raise planning.stop(
                "no_feasible_candidate", none_feasible_message(verdicts, pick.test_mode)
            )
        chosen = verdicts[-1]  # the reference proceeds with the last candidate tested
        planning.chosen = chosen
    row["chosen_index"] = chosen.pose_index
    row["chosen_score"] = chosen.score
    T_base_chosen = T_base_candidates[chosen.position]
    axis = T_base_chosen[:3, planning.poses.approach_index]
    row["approach_angle_deg"] = math.degrees(math.acos(float(np.clip(-axis[2], -1.0, 1.0))))
    return Choice(chosen, T_base_chosen)


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
    setup.mark_stepped()
    result.timings["warmup_steps"] = float(warmup_steps)
    job = ExecutionJob(
        scene, setup.task, targets, setup.facts.object_init_position,
        planning.poses.lift_offset, setup.planner.checker, setup.semantics, warmup_steps,
        record=True, log_ctrl=setup.spec.log_ctrl,
    )  # fmt: skip
    execution = engine_for(setup.spec.engine).execute(job)
    if execution.outcome is None:
        raise EpisodeStopError(
            "sim_unstable", f"during the warm-up steps: {execution.warmup_unstable}"
        )
    outcome = execution.outcome
    result.timings["sim_s"] = time.perf_counter() - clock
    result.timings["validity_s"] = outcome.validity_time_s
    if execution.ctrl_log is not None:
        result.ctrl_log = execution.ctrl_log
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
    row.update(validity_columns(execution.validity, outcome.table_penetration_m, outcome.validity))
    if outcome.failure_reason:
        raise EpisodeStopError(outcome.failure_reason, outcome.message)
