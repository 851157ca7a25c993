"""The validity phase: does the grasp really hold? Run after the reference verdict.

The reference verdict (a finger touches, velocities under 5, lift above ``lift_th``) accepts
one-finger grasps, fingers through a non-physical table and grasps that drop the object a second
later. After that verdict has been taken (so every reference column is what it was without this
phase), the episode goes on in the same simulation:

1. finish: the rest of the planned motion plays out (commands pop within ``t_eps``, before the
   lift segment ends); the table penetration is tracked through it;
2. rest: up to ``REST_WAIT_S`` for the object to come to rest (speed < ``REST_SPEED``);
3. hold: ``hold_time`` s at the lifted pose; then the slip is the drift of the object's pose
   relative to the TCP from the end of the closing window to the end of the hold (through the
   lift and the hold), in translation (``hold_slip_m``, the object origin) and rotation
   (``hold_rotation_rad``); then the lift and both finger forces are read;
4. tug (when the object is lifted and the hold was stable): a force of k x g x mass on the
   object's centre of mass (``xfrc_applied``) for ``TUG_TIME_S``, along +x, -x, +y, -y, +z, -z
   (DexGraspNet's six gravity directions), k in 0.5, 1, 2, 4 (GraspDataGen's multiples of g x
   mass). Every rung starts from the held state (saved with ``mj_getState`` at the end of the
   hold, restored with ``mj_setState``). A rung is survived when the object is still between the
   fingers (both still touch it) and its slip since the end of the hold is under ``TUG_MAX_SLIP``.
   ``robustness_g`` is the largest k survived in every direction (0 when some direction fails at
   0.5). Cost: each direction tries the levels from the best one every earlier direction
   survived downwards and stops at the first it survives, taking a grasp that holds k g to hold
   any smaller pull: a robust grasp costs six rungs (3 s of simulated time), not 24.

The checks themselves are ``harness.pick.verdict.validity_terms``; strict semantics use them as
their success. The phase holds the servos' last setpoints: the arm holds the lifted pose and the
gripper keeps squeezing, as a robot waiting for its next command would.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Protocol

import mujoco
import numpy as np

from harness.config import PickConfig
from harness.pick.outcome import ValidityColumns, ValidityMeasure, ValidityResult
from harness.pick.recorder import TugRecord, ValidityTrace
from harness.pick.semantics import Semantics
from harness.pick.terms import ROBUSTNESS_LEVELS_G
from harness.sim import ArmHandles, Scene, SceneObject

REST_SPEED = 0.02  # m/s: the object is "at rest" below this
REST_WAIT_S = 1.0  # how long the phase waits for the object to come to rest
TUG_LEVELS_G = ROBUSTNESS_LEVELS_G
TUG_TIME_S = 0.5
TUG_MAX_SLIP = 0.01  # m
TUG_DIRECTIONS: tuple[tuple[str, tuple[float, float, float]], ...] = (
    ("+x", (1.0, 0.0, 0.0)),
    ("-x", (-1.0, 0.0, 0.0)),
    ("+y", (0.0, 1.0, 0.0)),
    ("-y", (0.0, -1.0, 0.0)),
    ("+z", (0.0, 0.0, 1.0)),
    ("-z", (0.0, 0.0, -1.0)),
)
# The state a tug direction starts from: physics, time, controls, applied forces, warm start.
SAVED_STATE = mujoco.mjtState.mjSTATE_INTEGRATION | mujoco.mjtState.mjSTATE_WARMSTART


# A tug rung's result: survived, slip since the end of the hold (m), still between the fingers.
RungOutcome = tuple[bool, float, bool]


def tug_rung_steps(control_dt: float) -> int:
    """Control steps of one tug rung (``TUG_TIME_S``)."""
    return max(1, round(TUG_TIME_S / control_dt))


def tug_ladder(
    rung: Callable[[str, tuple[float, float, float], float], RungOutcome],
) -> tuple[float, str]:
    """The ladder's order and result: each direction tries the levels from the best one every
    earlier direction survived downwards, stops at the first it survives; ``robustness_g`` is
    the last direction's level (0 once one direction survives none). A rung starts from the
    held state, so its result does not depend on the order it is run in."""
    best = TUG_LEVELS_G[-1]
    message = ""
    for name, direction in TUG_DIRECTIONS:
        survived_level = 0.0
        for k in sorted((level for level in TUG_LEVELS_G if level <= best), reverse=True):
            survived, slip, between = rung(name, direction, k)
            if survived:
                survived_level = k
                break
            if not message or k == TUG_LEVELS_G[0]:
                where = "between the fingers" if between else "no longer between the fingers"
                message = f"{name} at {k:g} g: slip {slip * 1e3:.1f} mm, {where}"
        best = survived_level
        if best == 0.0:
            break
    return best, message


def phase_steps(hold_time: float, control_dt: float) -> int:
    """Control steps the phase can take after the motion finishes (the recorder's capacity)."""
    seconds = REST_WAIT_S + hold_time + len(TUG_DIRECTIONS) * len(TUG_LEVELS_G) * TUG_TIME_S
    return math.ceil(seconds / control_dt) + len(TUG_DIRECTIONS) * len(TUG_LEVELS_G) + 2


class PhaseHost(Protocol):
    """What the phase needs of the executor that ran the pick."""

    scene: Scene
    handles: ArmHandles
    obj: SceneObject
    control_dt: float
    substeps: int

    def finish_step(self) -> bool:
        """One control step of the remaining planned motion; True when none is left."""
        ...

    def hold_step(self, label: str) -> None:
        """One control step with the servos holding their setpoints (recorded as ``label``)."""
        ...

    def object_speed(self) -> float: ...

    def event(self, text: str) -> None: ...

    def object_in_tcp(self) -> np.ndarray: ...

    def object_pose_in_tcp(self) -> np.ndarray: ...

    @property
    def grasp_reference(self) -> np.ndarray | None:
        """The object's pose in the TCP frame when the closing ended."""
        ...

    @property
    def time(self) -> float: ...


class ValidityPhase:
    """Runs the phase on a host (``PickExecutor``) and returns the ``ValidityMeasure``."""

    def __init__(self, host: PhaseHost, hold_time: float, object_init_z: float) -> None:
        self.host = host
        self.scene = host.scene
        self.hold_time = hold_time
        self.object_init_z = object_init_z
        self.times: list[float] = []
        self.slips: list[float] = []
        self.stages: list[str] = []
        self.tugs: list[TugRecord] = []

    def run(self, measure: ValidityMeasure) -> ValidityMeasure:
        host, scene = self.host, self.scene
        while not host.finish_step():
            pass
        waited = 0.0
        while host.object_speed() >= REST_SPEED and waited < REST_WAIT_S - 1e-9:
            host.hold_step("validity:rest")
            waited += host.control_dt
            self._sample("rest", 0.0)
        reference = host.object_in_tcp()
        host.event("validity: hold")
        for _ in range(max(0, math.ceil(self.hold_time / host.control_dt - 1e-9))):
            host.hold_step("validity:hold")
            self._sample("hold", float(np.linalg.norm(host.object_in_tcp() - reference)))
        d = scene.data
        arm = host.handles.name
        measure.ran = True
        closed = host.grasp_reference
        measure.hold_slip_m, measure.hold_rotation_rad = pose_drift(
            closed if closed is not None else np.eye(4), host.object_pose_in_tcp()
        )
        if closed is None:  # never closed: the hold alone
            measure.hold_slip_m = float(np.linalg.norm(host.object_in_tcp() - reference))
            measure.hold_rotation_rad = 0.0
        measure.finger_forces = scene.finger_forces(arm, host.obj.name)
        measure.lift_height_m = float(d.xpos[host.obj.body_id][2] - self.object_init_z)
        measure.object_speed = float(
            np.max(np.abs(d.qvel[host.obj.dof_adr : host.obj.dof_adr + 3]))
        )
        measure.joint_speed = scene.robot_joint_speed()
        if scene.unstable() is not None:
            measure.hold_slip_m = math.inf
        if measure.lift_height_m > 0.0 and np.isfinite(measure.hold_slip_m):
            measure.robustness_g, measure.tug_message = self._tug()
        else:
            measure.robustness_g, measure.tug_message = 0.0, "not tugged: the object is not held"
        measure.trace = ValidityTrace(
            np.asarray(self.times), np.asarray(self.slips), np.asarray(self.stages, dtype=str),
            self.tugs,
        )  # fmt: skip
        return measure

    def _sample(self, stage: str, slip: float) -> None:
        self.times.append(self.host.time)
        self.slips.append(slip)
        self.stages.append(stage)

    def _tug(self) -> tuple[float, str]:
        """The tug ladder from the held state; (robustness_g, the first failed rung)."""
        host, m, d = self.host, self.scene.model, self.scene.data
        body = host.obj.body_id
        weight = float(m.body_subtreemass[body]) * float(np.linalg.norm(m.opt.gravity))
        state = np.empty(mujoco.mj_stateSize(m, SAVED_STATE))
        mujoco.mj_getState(m, d, state, SAVED_STATE)
        reference = host.object_in_tcp()
        host.event("validity: tug")
        rung_steps = tug_rung_steps(host.control_dt)

        def rung(name: str, direction: tuple[float, float, float], k: float) -> RungOutcome:
            mujoco.mj_setState(m, d, state, SAVED_STATE)
            force = np.asarray(direction) * k * weight
            d.xfrc_applied[body, :3] = force
            t_start = host.time
            for _ in range(rung_steps):
                host.hold_step(f"validity:tug {name} {k:g} g")
                self._sample("tug", float(np.linalg.norm(host.object_in_tcp() - reference)))
            slip = self.slips[-1]
            between = self._between_fingers()
            survived = slip < TUG_MAX_SLIP and between and self.scene.unstable() is None
            self.tugs.append(TugRecord(name, k, force, t_start, host.time, slip, between, survived))
            return survived, slip, between

        best, message = tug_ladder(rung)
        mujoco.mj_setState(m, d, state, SAVED_STATE)
        d.xfrc_applied[body] = 0.0
        mujoco.mj_forward(m, d)
        return best, message

    def _between_fingers(self) -> bool:
        """The object is still between the fingers: each finger still touches it. (A test on
        the centre of mass would fail grasps that hold a mug by its rim.)"""
        forces = self.scene.finger_forces(self.host.handles.name, self.host.obj.name)
        return min(forces) > 0.0


def pose_drift(T_before: np.ndarray, T_after: np.ndarray) -> tuple[float, float]:
    """How far a pose moved: (translation in m, rotation angle in rad) between two 4 x 4 poses
    in the same frame."""
    translation = float(np.linalg.norm(T_after[:3, 3] - T_before[:3, 3]))
    R = T_before[:3, :3].T @ T_after[:3, :3]
    cos = float(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0))
    return translation, math.acos(cos)


def validity_columns(
    enabled: bool, penetration_m: float, result: ValidityResult | None
) -> ValidityColumns:
    """The row's validity columns (``harness.row.EpisodeRow``).

    ``enabled`` False (``validity: off`` under reference): ``valid`` False, ``invalid_reason``
    '' and NaN measurements, except ``table_penetration_m`` (a fact of the motion, NaN when
    nothing executed). An enabled episode without a result never reached its verdict:
    ``not_run``."""
    if not enabled:
        return ValidityColumns(penetration_m)
    if result is None:
        return ValidityColumns(penetration_m, valid=False, invalid_reason="not_run")
    measure = result.measure
    return ValidityColumns(
        penetration_m,
        valid=result.valid,
        invalid_reason=result.invalid_reason,
        robustness_g=measure.robustness_g,
        hold_slip_m=measure.hold_slip_m,
        hold_rotation_rad=measure.hold_rotation_rad,
        min_finger_force_n=measure.min_finger_force_n,
    )


def validity_enabled(pick: PickConfig) -> bool:
    """The phase runs with ``validity: on``, and always under strict (its verdict)."""
    return pick.validity or Semantics.from_pick(pick).validity_is_verdict
