"""The per-step record of an episode for viewers (``EpisodeTrace``) and how it is assembled.

What a viewer needs of one episode: joint and object trajectories, TCP poses, gripper width,
finger forces, phases and events (from the execution's ``ExecutionTrace``), every candidate with
its verdict (rejected by the filters, passed, infeasible, feasible, chosen), and the planned and
executed TCP paths.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from harness.grasps import CandidateSelection
from harness.pick.outcome import PickOutcome
from harness.pick.recorder import FingerContacts, ValidityTrace
from harness.pick.targets import PickTargets
from harness.planning.ik import WholeBodyIK
from harness.planning.plans import CandidateVerdict
from harness.planning.timing import Trajectory
from harness.sim import Scene

# Candidate verdict labels (also used by the Rerun recorder's colours). ``fallback``: nothing
# was feasible and the reference proceeded with this last tested (infeasible) candidate.
REJECTED, PASSED, INFEASIBLE, FEASIBLE, CHOSEN, FALLBACK = (
    "rejected",
    "passed",
    "infeasible",
    "feasible",
    "chosen",
    "fallback",
)
MAX_TRACE_CANDIDATES = 600


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
    validity: ValidityTrace | None = None  # the validity phase: slip series, tug rungs
    # The scene before any motion: the reset state when nothing was executed (the episode
    # stopped at the filters, the feasibility test or the plan), else the first executed row.
    qpos_start: np.ndarray | None = None  # (nq,)
    contacts: FingerContacts | None = None  # finger-object contacts per row (points, forces)
    # The distinct tested candidates in test order, and the world poses each was tested at.
    tested_index: np.ndarray | None = None  # (K,) pose index
    tested_status: np.ndarray | None = None  # (K,) str: infeasible/feasible/chosen/fallback
    tested_T_world_pregrasp: np.ndarray | None = None  # (K, 4, 4)
    tested_T_world_grasp: np.ndarray | None = None  # (K, 4, 4)


def planned_tcp(
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


def make_trace(
    scene: Scene,
    arm: str,
    selection: CandidateSelection,
    T_world_base: np.ndarray,
    verdicts: list[CandidateVerdict],
    chosen: CandidateVerdict | None,
    outcome: PickOutcome | None,
    targets: PickTargets | None,
    planned: tuple[np.ndarray, np.ndarray, np.ndarray] | None,
    T_world_object_start: np.ndarray,
) -> EpisodeTrace:
    d = scene.data
    # Candidates: every tested pose, then passing and rejected poses, each up to a cap.
    status: dict[int, str] = {}
    detail: dict[int, str] = {}
    for v in verdicts:
        status[v.pose_index] = FEASIBLE if v.feasible else INFEASIBLE
        detail[v.pose_index] = "" if v.feasible else f"{v.stage}: {v.detail}"
    if chosen is not None:
        status[chosen.pose_index] = CHOSEN if chosen.feasible else FALLBACK
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
        T_world_object_start=T_world_object_start,
        T_world_grasp=targets.T_world_grasp if targets else None,
        T_world_pregrasp=targets.T_world_pregrasp if targets else None,
        T_world_lift=targets.T_world_lift if targets else None,
        validity=ex.validity if ex else None,
        qpos_start=ex.qpos[0].copy() if ex is not None and len(ex.qpos) else d.qpos.copy(),
        contacts=ex.contacts if ex else None,
        **_tested_targets(verdicts, status),
    )


def _tested_targets(verdicts: list[CandidateVerdict], status: dict[int, str]) -> dict:
    """The distinct tested candidates in test order with the poses they were tested at."""
    first: dict[int, CandidateVerdict] = {}
    for verdict in verdicts:
        if verdict.T_world_pregrasp is not None and verdict.T_world_grasp is not None:
            first.setdefault(verdict.pose_index, verdict)
    tested = list(first.values())
    empty = np.zeros((0, 4, 4))
    return {
        "tested_index": np.array([v.pose_index for v in tested], dtype=np.int64),
        "tested_status": np.array([status[v.pose_index] for v in tested], dtype=str),
        "tested_T_world_pregrasp": np.array([v.T_world_pregrasp for v in tested]).reshape(-1, 4, 4)
        if tested
        else empty,
        "tested_T_world_grasp": np.array([v.T_world_grasp for v in tested]).reshape(-1, 4, 4)
        if tested
        else empty,
    }
