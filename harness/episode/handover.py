"""A handover's second pick, run from the state the reference gives it.

InternDataEngine's handover files (``tasks/long_horizon/split_aloha/handover/lr/bowl.yaml``
153-195, commit c4fa389) run in one episode: the first arm's ``pick`` (lifted 0.1 m), its
``goto__pose`` (the held object carried to a pose in that arm's base frame), then the other
arm's ``pick`` of the object in mid-air; only after it do the grippers change hands (the next
phase: ``gripper__action`` close on the second arm, open on the first, 196-211). The skills are
built at the reset (simbox_dual_workflow.py ``_initialize_skills``) and each one generates its
commands when the one before it is done (``update_skill_states``), so the second pick draws its
candidates from the object's pose **in mid-air** (pick.py ``get_ee_poses``: the object's pose
when its commands are generated).

``run_handover`` does the same in one MuJoCo scene, phase after phase:

1. ``first_pick``: the reset (the first arm's home and noise) and the first pick on the normal
   path (candidates, feasibility, plan, execution, its own reference verdict), without a
   validity phase (its tug would shake the object the second pick takes);
2. ``goto_pose``: the reference's goto targets (``harness.pick.goto_pose``) tested in order with
   the planner of the first arm (object attached, ``carry`` phase), the first feasible one
   executed with the gripper closed, then the reference's idle wait. Its own success test
   (within 5 mm or 0.087 rad, goto_pose.py 264-272) is measured (``goto_error_mm``,
   ``goto_error_rad``), not judged: a failed goto only clears the reference's episode success,
   its second pick still runs (simbox_dual_workflow.py 410-412), and the row is that pick's
   verdict;
3. the second pick on the normal path from the scene as phases 1-2 left it: candidates from the
   object's current pose in the second arm's base frame, filtered, ordered, tested and planned
   as any pick, executed and judged by its own block's reference rule (the handover files set
   no ``lift_th`` and no lift: success = a finger of the second gripper touches the object and
   the velocities stay under 5, pick.py ``is_success`` 334-351).

A failure in phase 1 or 2 ends the episode with the usual failure reason and the
``failure_stage`` prefixed ``first_pick:`` or ``goto_pose:``. The reference's episode fails
there too: a plan that cannot be made stops it (``is_feasible``), a failed verdict clears its
success. (After a failed first-pick verdict the reference would still run the later skills on
an object that is not held: no handover, so the harness stops there.) A goto that leaves the
object out of the first gripper is ``dropped`` at ``goto_pose:execute`` (chosen, for the same
reason: the reference would let the second pick reach for the object wherever it fell).

The valid verdict of the second pick (``harness.pick.release``): the first gripper opens as the
reference's next phase does, then the usual validity phase (rest, hold, tug ladder) runs with
the second gripper alone holding; valid also needs the opened first gripper to carry no force
on the object at the end of the release. So "valid" means: the object ends held by the second
gripper.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any, cast

import numpy as np

from harness.config import TaskConfig
from harness.config.handover import HandoverPrelude
from harness.episode import location
from harness.episode.candidate_cache import ResetFacts
from harness.episode.evaluation import SeedEvaluation
from harness.episode.execution import execute_chosen
from harness.episode.planning import candidates, feasibility
from harness.episode.records import (
    FailureLocationColumns,
    GotoColumns,
    RowRecord,
    SceneColumns,
)
from harness.episode.result import EpisodeResult
from harness.episode.scene_cache import SceneBundle
from harness.episode.setup import EpisodeStopError, Setup, reset
from harness.episode.spec import EpisodeSpec
from harness.episode.streams import EpisodeStreams, HandoverStreams
from harness.errors import HarnessError
from harness.failures import FailureReason
from harness.pick.goto_pose import goto_reached, goto_targets
from harness.pick.semantics import Semantics
from harness.pick.servo import ServoTiming
from harness.planning.chain_timing import TOPPRA_GRIDPOINTS
from harness.planning.timing import TimingError, TimingLimits, plan_timing
from harness.sim import Scene
from harness.transforms import invert_T

FIRST_PICK = "first_pick"
GOTO_POSE = "goto_pose"
# The reference's is_done after a goto's plan has played: the pose within 1 mm / 5e-3 rad
# (goto_pose.py is_subtask_done defaults, 244) or more than 10 idle control steps
# (``num_last_cmd > 10``).
GOTO_IDLE_STEPS = 11


def first_pick_task(task: TaskConfig) -> TaskConfig:
    """The first pick as a task of the same scene (objects, physics, grip, placement): the
    prelude's arm, home and pick block, without a validity phase."""
    prelude = task.handover
    assert prelude is not None
    pick = prelude.pick.model_copy(update={"validity": False})
    return task.model_copy(
        update={
            "name": f"{task.name}:{FIRST_PICK}",
            "arm": prelude.arm,
            "home": prelude.home,
            "home_noise_std": prelude.home_noise_std,
            "pick": pick,
            "handover": None,
        }
    )


def _prefixed(records: tuple[RowRecord, ...] | list[RowRecord], phase: str) -> list[RowRecord]:
    """``records`` with the failure stage named after the phase it failed in."""
    out: list[RowRecord] = []
    for record in records:
        if isinstance(record, FailureLocationColumns):
            stage = f"{phase}:{record.failure_stage}" if record.failure_stage else phase
            record = dataclasses.replace(record, failure_stage=stage)
        out.append(record)
    return out


def _in_phase(stop: EpisodeStopError, phase: str) -> EpisodeStopError:
    """``stop`` with its message naming the phase (its location goes to the records)."""
    return EpisodeStopError(cast(FailureReason, stop.reason), f"{phase}: {stop.message}")


def run_handover(
    spec: EpisodeSpec,
    scene_cache: dict[Any, Any] | None,
    result: EpisodeResult,
    records: list[RowRecord],
) -> None:
    """The three phases (module docstring); raises ``EpisodeStopError`` where one fails."""
    task = spec.task
    prelude = task.handover
    assert prelude is not None
    if prelude.arm == task.arm:
        raise HarnessError(f"handover.arm {prelude.arm!r} is the arm of the second pick")
    # 1. The first pick, on the normal path.
    first_spec = dataclasses.replace(spec, task=first_pick_task(task), trace=False)
    first_records: list[RowRecord] = []
    try:
        setup = reset(first_spec, scene_cache, result, SeedEvaluation(), first_records)
        planning = candidates(setup)
        executed = execute_chosen(planning, feasibility(planning))
    except EpisodeStopError as stop:
        where = stop.where if stop.where is not None else location.stage_failure("")
        records.extend(_prefixed([*first_records, where], FIRST_PICK))
        raise _in_phase(stop, FIRST_PICK) from None
    if executed.stop is not None:
        records.extend(_prefixed([*first_records, *executed.records], FIRST_PICK))
        reason, message = executed.stop
        raise EpisodeStopError(reason, f"{FIRST_PICK}: {message}")  # type: ignore[arg-type]
    streams = HandoverStreams(spec.seed)
    # 2. The goto, by the first arm, object in hand.
    if prelude.goto_pose is not None:
        clock = time.perf_counter()
        try:
            goto = _goto(setup, prelude, streams)
        except EpisodeStopError as stop:
            where = stop.where if stop.where is not None else location.stage_failure("")
            records.extend(_prefixed([where], GOTO_POSE))
            raise _in_phase(stop, GOTO_POSE) from None
        records.append(goto)
        result.timings["goto_s"] = time.perf_counter() - clock
    # 3. The second pick from the state left.
    second = _second_setup(spec, setup.bundle, result, setup.facts, streams, records)
    planning = candidates(second)
    executed = execute_chosen(planning, feasibility(planning))
    records.extend(executed.records)
    if executed.stop is not None:
        raise EpisodeStopError(*executed.stop)  # type: ignore[arg-type]


def _second_setup(
    spec: EpisodeSpec,
    bundle: SceneBundle,
    result: EpisodeResult,
    first_facts: ResetFacts,
    streams: EpisodeStreams,
    records: list[RowRecord],
) -> Setup:
    """The second pick's ``Setup`` on the scene as it is now: its "reset facts" are the object
    held in mid-air and the second arm where it stands; ``obj_init_trans`` stays the object's
    pose at the reset (the reference builds every skill then: pick.py 56)."""
    task = spec.task
    scene = bundle.scene
    target = task.target_object.name
    gripper = scene.robot.arm(task.arm).gripper
    semantics = Semantics.from_pick(task.pick)
    asset = scene.objects[target].asset
    columns = (asset.friction, asset.mass, gripper.force_limit, scene.robot.gripper_variant)
    records.append(SceneColumns(*columns, task.pick.speed_scale, semantics.name))
    facts = ResetFacts(
        T_world_base=scene.T_world_base(task.arm),
        T_world_object=scene.T_world_object(target),
        object_init_position=first_facts.object_init_position,
        q_now=scene.active_q(task.arm),
        settle_steps=0,
        unstable=None,
    )
    records.append(location.placement_columns(facts.T_world_base, facts.T_world_object))
    evaluation = SeedEvaluation(key=("handover", spec.seed))
    evaluation.memory.reset = facts
    evaluation.mark_reset(bundle)  # the scene holds the state this pick starts from
    planner = bundle.planner(task.arm)
    return Setup(spec, result, semantics, bundle, streams, evaluation, planner, records)


def _goto(setup: Setup, prelude: HandoverPrelude, streams: HandoverStreams) -> GotoColumns:
    """2. The goto: targets, the first feasible one planned and executed; its columns."""
    config = prelude.goto_pose
    assert config is not None
    scene, arm = setup.scene, prelude.arm
    handles = scene.arms[arm]
    target = setup.task.target_object.name
    T_world_base = scene.T_world_base(arm)
    T_world_ee = scene.T_world_body(handles.ee_body)
    T_obj_ee = invert_T(scene.T_world_object(target)) @ T_world_ee
    rng = streams.goto()
    T_base_targets, _passed = goto_targets(config, T_obj_ee, rng)
    planner = setup.planner
    planner.sync(setup.semantics.planning_world(target))
    q_now = scene.active_q(arm)
    planner.checker.attach(q_now)  # the object stays attached since the pick (no detach)
    path, why, T_base_goal = None, "no target", T_base_targets[-1]
    try:
        for T_base_target in T_base_targets:
            T_world_target = T_world_base @ T_base_target
            if config.test_mode == "ik":
                ik, why = planner.collision_free_ik(T_world_target, [q_now], "carry", rng)
                if ik.success and not why:
                    path = np.stack([q_now, ik.q])
            else:
                path, why = planner.joint_space_path(q_now, T_world_target, "carry", rng)
            if path is not None:
                T_base_goal = T_base_target
                break
    finally:
        planner.checker.detach()
    if path is None:
        where = location.plan_failure("targets", planner.last_failure)
        why = f"none of {len(T_base_targets)} targets planned ({why})"
        raise EpisodeStopError("plan_failed", why, where)
    return _play_goto(setup, prelude, path, T_world_base @ T_base_goal)


def _play_goto(
    setup: Setup, prelude: HandoverPrelude, path: np.ndarray, T_world_goal: np.ndarray
) -> GotoColumns:
    """Time the goto's joint path at the first pick's pace and play it on the first arm's
    servos (gripper holding its squeeze), then the reference's idle wait; the distance to the
    goal is measured against the reference's success test (5 mm or 0.087 rad), not judged
    (module docstring)."""
    scene, task, arm = setup.scene, setup.task, prelude.arm
    handles = scene.arms[arm]
    names = handles.active_names
    robot = scene.robot
    acceleration, jerk = task.timing.factors(names, robot.lift_joint)  # the chosen limits' keys
    limits = TimingLimits(
        robot.velocity_limits(names), robot.acceleration_limits(names) * acceleration,
        robot.jerk_limits(names) * jerk, prelude.pick.speed_scale,
    )  # fmt: skip
    try:
        trajectory = plan_timing(
            path, limits, prelude.pick.timing, names, GOTO_POSE, TOPPRA_GRIDPOINTS
        )
    except TimingError as exc:
        raise EpisodeStopError(
            "plan_failed", f"timing: {exc}", location.stage_failure("plan:timing")
        ) from None
    servo = ServoTiming(scene.model, handles, task.control_dt)
    ctrl = scene.data.ctrl
    for row in servo.arm_setpoints(trajectory):
        for chunk, size in enumerate(servo.chunk_sizes):
            ctrl[handles.active_actuators] = row[chunk]
            scene.step(size)
        _check_stable(scene)
    for _ in range(GOTO_IDLE_STEPS):
        if _reached_tight(scene.T_world_body(handles.ee_body), T_world_goal):
            break
        scene.step(servo.substeps)
        _check_stable(scene)
    T_base_world = invert_T(scene.T_world_base(arm))
    T_base_ee = T_base_world @ scene.T_world_body(handles.ee_body)
    _, position_error, orientation_error = goto_reached(T_base_ee, T_base_world @ T_world_goal)
    forces = scene.finger_forces(arm, task.target_object.name)
    if max(forces) <= 0.0:
        why = f"the object left the {arm} gripper during the goto"
        raise EpisodeStopError("dropped", why, location.stage_failure("execute"))
    return GotoColumns(position_error * 1e3, orientation_error)


def _reached_tight(T_ee: np.ndarray, T_goal: np.ndarray) -> bool:
    """goto_pose.py is_subtask_done with its defaults: 1 mm and 5e-3 rad."""
    position_error = float(np.linalg.norm(T_ee[:3, 3] - T_goal[:3, 3]))
    relative = T_ee[:3, :3].T @ T_goal[:3, :3]
    angle = float(np.arccos(np.clip((np.trace(relative) - 1.0) / 2.0, -1.0, 1.0)))
    return position_error < 1e-3 and angle < 5e-3


def _check_stable(scene: Scene) -> None:
    reason = scene.unstable()
    if reason is not None:
        raise EpisodeStopError("sim_unstable", reason, location.stage_failure("execute"))
