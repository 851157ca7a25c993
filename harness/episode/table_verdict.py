"""The table term of the valid verdict, decided by physics instead of by a depth threshold.

A depth bound on robot-table overlap (``MAX_TABLE_PENETRATION``, 2 mm, no source) sits inside
MuJoCo's contact softness, so a verdict that flips on it is not physical. Instead:

- where the task makes robot-table contact **non-physical** (``physics.table_contact: false``,
  the reference's ``neglect_collision_names: [table]``) and a robot geom went below the table
  top (``table_penetration_m > 0``) in a reference success, the same plan (the same control
  schedule, from the same start state) is executed again on a table-physical variant of the
  scene (``table_physical``: the robot geoms get the table's contact bit); the pick is valid
  when that execution still grasps, lifts and holds (its reference verdict and its validity
  terms, the table term left out since the table now stops the fingers). Otherwise it is
  invalid with ``invalid_reason`` ``table_penetration``;
- where robot-table contact is **physical**, the contact model already stops the fingers: the
  depth is reported, the table term does not judge.

Either way ``table_penetration_m`` keeps the depth measured in the episode's own execution, and
``table_replay`` says what the replay found ('' when none ran, ``held``, or the cause it
failed with). The replay is a second execution of the same ``ExecutionJob`` on the same
``Scene`` with the table bits set. Under ``semantics: strict`` the validity verdict is the
success and stays the execution's own.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from contextlib import contextmanager

import mujoco
import numpy as np

from harness.config import TaskConfig
from harness.pick.execution_job import Execution, ExecutionJob, execute_job
from harness.pick.outcome import PickOutcome, ValidityMeasure, ValidityResult
from harness.pick.verdict import first_failure, validity_terms
from harness.sim import Scene
from harness.sim.masks import TABLE_BIT, refresh_body_masks

TABLE_TERM = "table_penetration"
HELD = "held"
# What a replay restores: physics, time, controls, applied forces, equality state, warm start.
START_STATE = mujoco.mjtState.mjSTATE_INTEGRATION | mujoco.mjtState.mjSTATE_WARMSTART


@contextmanager
def table_physical(scene: Scene) -> Iterator[None]:
    """The scene with robot-table contact on: every colliding robot geom gets the table's
    contact bit (as ``physics.table_contact: true`` composes it); restored on exit."""
    model = scene.model
    robot = scene.robot_geom & (model.geom_conaffinity != 0)
    saved = model.geom_conaffinity.copy()
    model.geom_conaffinity[robot] |= TABLE_BIT
    refresh_body_masks(model)
    try:
        yield
    finally:
        model.geom_conaffinity[:] = saved
        refresh_body_masks(model)


def start_state(scene: Scene) -> np.ndarray:
    """The scene's state to replay an execution from (``START_STATE``)."""
    size = mujoco.mj_stateSize(scene.model, START_STATE)
    state = np.empty(size)
    mujoco.mj_getState(scene.model, scene.data, state, START_STATE)
    return state


def may_replay(task: TaskConfig) -> bool:
    """Whether ``task``'s picks can be replayed on a physical table: reference semantics with
    robot-table contact non-physical."""
    return task.pick.semantics == "reference" and not task.physics.table_contact


def needs_replay(task: TaskConfig, outcome: PickOutcome | None) -> bool:
    """A reference success under reference semantics, robot-table contact non-physical, with a
    robot geom below the table top during its execution."""
    if outcome is None or outcome.validity is None or not outcome.success:
        return False
    return may_replay(task) and outcome.table_penetration_m > 0.0


def replay_on_physical_table(job: ExecutionJob, state: np.ndarray) -> Execution:
    """Execute ``job`` again from ``state`` with the table physical (no recording)."""
    scene = job.scene
    mujoco.mj_setState(scene.model, scene.data, state, START_STATE)
    mujoco.mj_forward(scene.model, scene.data)
    with table_physical(scene):
        return execute_job(dataclasses.replace(job, record=False, log_ctrl=False))


def judged_without_table(task: TaskConfig, measure: ValidityMeasure) -> ValidityResult:
    """The validity terms on ``measure`` with the table term left out."""
    terms = [t for t in validity_terms(task.pick, measure) if t.name != TABLE_TERM]
    failed = first_failure(terms)
    if failed is None:
        return ValidityResult(True, "", "", measure)
    return ValidityResult(False, failed.name, failed.message, measure)


def physical_verdict(
    task: TaskConfig, first: ValidityResult | None, replay: Execution | None
) -> tuple[ValidityResult | None, str]:
    """The episode's validity result and its ``table_replay`` column.

    ``first``: the validity result of the episode's execution; ``replay``: the execution on
    the physical table (``needs_replay``), else None."""
    if first is None or task.pick.semantics != "reference":
        return first, ""
    if replay is None:
        if first.invalid_reason != TABLE_TERM:
            return first, ""
        if not first.measure.ran:  # stopped before its verdict: the motion's facts only
            return ValidityResult(False, "not_run", first.message, first.measure), ""
        # physical table (or nothing touched it): the depth is the contact's softness
        return judged_without_table(task, first.measure), ""
    outcome = replay.outcome
    if outcome is None or not outcome.success or outcome.validity is None:
        cause = "sim_unstable" if outcome is None else outcome.failure_reason or "not_run"
        message = replay.warmup_unstable if outcome is None else outcome.message
        return (
            ValidityResult(
                False, TABLE_TERM, f"with the table physical the pick fails: {message}",
                first.measure,
            ),
            cause,
        )  # fmt: skip
    held = judged_without_table(task, outcome.validity.measure)
    if held.valid:
        return held, HELD
    return (
        ValidityResult(False, TABLE_TERM, f"with the table physical: {held.message}", held.measure),
        held.invalid_reason,
    )
