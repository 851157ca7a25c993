"""The planning stages of an episode: the candidates, then their feasibility test.

2. ``candidates``: the annotated grasps in the arm base frame, filtered and ordered (the
   reference's weighted draw or the strict order), and the lift offset.
3. ``feasibility``: candidate by candidate, in the planning world of the semantics, until one
   passes (verdicts already known for this seed are reused,
   ``harness.episode.evaluation.SeedEvaluation.walk``).

Each returns its row columns as records (``harness.episode.records``) on ``Setup.records``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from harness.episode import location
from harness.episode.records import (
    CandidateColumns,
    ChoiceColumns,
    FailureLocationColumns,
    PlanTimeColumns,
    TestedColumns,
)
from harness.episode.scene_cache import grasp_file_for
from harness.episode.setup import EpisodeStopError, Setup
from harness.episode.trace import add_failure_point, make_trace
from harness.failures import FailureReason
from harness.grasps import CandidateSelection, select_candidates
from harness.pick.outcome import PickOutcome
from harness.pick.selection import candidate_failures_json, none_feasible_message
from harness.pick.targets import CandidatePoses, PickTargets
from harness.planning.plans import CandidateVerdict, FailurePoint
from harness.transforms import invert_T, quat_to_matrix


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
    plan_time: PlanTimeColumns | None = None  # once the planning clock stopped

    def finish_trace(
        self,
        outcome: PickOutcome | None,
        targets: PickTargets | None,
        planned: tuple[np.ndarray, np.ndarray, np.ndarray] | None,
    ) -> None:
        setup = self.setup
        if not setup.spec.trace:
            setup.result.trace = None
            return
        setup.result.trace = make_trace(
            setup.scene, setup.arm, self.selection, self.poses.T_world_base, self.verdicts,
            self.chosen, outcome, targets, planned, self.T_world_object_start,
        )  # fmt: skip

    def record_plan_time(self) -> PlanTimeColumns:
        """Stop the planning clock: the wall time from the selection to now, and the IK's."""
        self.plan_time = PlanTimeColumns(
            plan_time_s=time.perf_counter() - self.t0,
            ik_time_s=self.setup.planner.ik.total_time - self.ik_time_before,
        )
        self.setup.records.append(self.plan_time)
        return self.plan_time

    def stop(
        self,
        reason: FailureReason,
        message: str,
        where: FailureLocationColumns | None = None,
        point: FailurePoint | None = None,
    ) -> EpisodeStopError:
        """Record the planning time and the trace so far (with the configuration that failed,
        ``point``), and end the episode where it stopped (``harness.episode.location``)."""
        self.record_plan_time()
        self.finish_trace(None, None, None)
        add_failure_point(self.setup.result.trace, self.setup.scene, self.setup.arm, point)
        return EpisodeStopError(reason, message, where)


@dataclass(frozen=True)
class Choice:
    """The candidate chosen by the feasibility stage and its base-frame pose."""

    chosen: CandidateVerdict
    T_base_grasp: np.ndarray


def candidates(setup: Setup) -> Planning:
    """2. Candidates in the arm base frame, and the lift offset (its own stream)."""
    task, pick, scene, facts = setup.task, setup.pick, setup.scene, setup.facts
    ee_poses = setup.bundle.poses(task, grasp_file_for(task, scene))
    T_base_obj = invert_T(facts.T_world_base) @ facts.T_world_object
    t0 = time.perf_counter()
    selection = select_candidates(
        ee_poses, scene.robot.convention, pick, T_base_obj, setup.streams.candidates(),
        setup.semantics.candidates,
    )  # fmt: skip
    counts = selection.counts()
    lift_rng = setup.streams.lift()
    lift_offset = float(lift_rng.uniform(pick.post_grasp_offset_min, pick.post_grasp_offset_max))
    setup.records.append(
        CandidateColumns(counts["total"], counts["passed"], selection.order.outcome, lift_offset)
    )
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
        note = selection.order.note or "no pose passed the filters"
        raise EpisodeStopError("filter_empty", note, location.stage_failure("filter"))
    return planning


def feasibility(planning: Planning) -> Choice:
    """3. Feasibility, candidate by candidate, in the planning world of the semantics."""
    setup = planning.setup
    pick, semantics, planner = setup.pick, setup.semantics, setup.planner
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
                lift_path=semantics.lift_path,
            )  # fmt: skip
        verdict.T_world_pregrasp, verdict.T_world_grasp = T_pre, T_grasp
        return verdict

    planning.ik_time_before = planner.ik.total_time
    verdicts, chosen = setup.evaluation.walk(order.indices.tolist(), order.scores.tolist(), test)
    planning.verdicts, planning.chosen = verdicts, chosen
    setup.records.append(
        TestedColumns(
            n_tested=len(verdicts),
            n_feasible=len({v.pose_index for v in verdicts if v.feasible}),
            candidate_failures=candidate_failures_json(verdicts),
        )
    )
    if chosen is None:
        if not semantics.fall_back_to_last_tested or not verdicts:
            raise planning.stop(
                "no_feasible_candidate", none_feasible_message(verdicts, pick.test_mode),
                location.feasibility_failure(verdicts),
                verdicts[-1].failure_point if verdicts else None,
            )  # fmt: skip
        chosen = verdicts[-1]  # the reference proceeds with the last candidate tested
        planning.chosen = chosen
    T_base_chosen = T_base_candidates[chosen.position]
    axis = T_base_chosen[:3, planning.poses.approach_index]
    angle_deg = math.degrees(math.acos(float(np.clip(-axis[2], -1.0, 1.0))))
    setup.records.append(ChoiceColumns(chosen.pose_index, chosen.score, angle_deg))
    return Choice(chosen, T_base_chosen)
