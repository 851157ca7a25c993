"""What one pick execution measured and concluded (``PickOutcome``, ``ValidityMeasure``).

Its own module so that the verdict terms (``harness.pick.verdict``) read the measurements
without importing the control loop that fills them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from harness.failures import FailureReason
from harness.pick.recorder import ExecutionTrace, ValidityTrace

NAN = math.nan


@dataclass
class ValidityMeasure:
    """What the validity phase measured (``harness.pick.validity``); the inputs of the validity
    terms (``harness.pick.verdict.validity_terms``). ``ran`` is False when the phase did not run
    (then only ``table_penetration_m`` of the executed part is known)."""

    ran: bool = False
    table_penetration_m: float = NAN  # deepest robot geom below the table top (m)
    lift_height_m: float = NAN  # object rise over obj_init_trans at the end of the hold (m)
    closing_forces: tuple[float, float] = (NAN, NAN)  # when the closing ended (N)
    finger_forces: tuple[float, float] = (NAN, NAN)  # at the end of the hold (N)
    hold_slip_m: float = NAN  # object drift relative to the TCP, grasp closed -> hold end (m)
    hold_rotation_rad: float = NAN  # the same drift's rotation (rad)
    robustness_g: float = NAN  # largest tug level survived in every direction (0: none)
    tug_message: str = ""  # the first rung that failed
    object_speed: float = NAN  # object speed at the end of the hold (m/s)
    joint_speed: float = NAN  # max |robot joint speed| at the end of the hold
    # A handover's second pick: the opened first gripper's larger finger force on the object
    # after the release (N, harness.pick.release); NaN for every other pick.
    first_gripper_force_n: float = NAN
    trace: ValidityTrace | None = None

    @property
    def min_finger_force_n(self) -> float:
        """The weaker finger after the hold (NaN counts as 0). Not when the closing window
        ended: a slow gripper still closing then, which holds with both fingers through the
        lift and the hold, has a two-finger grasp (the tug checks both fingers again)."""
        return min(0.0 if force != force else force for force in self.finger_forces)


@dataclass(frozen=True)
class ValidityColumns:
    """The row's validity columns (``harness.row.EpisodeRow``); ``None``: not written (the row
    keeps its default), as ``harness.episode.records.merge_records`` reads it."""

    table_penetration_m: float | None = None
    valid: bool | None = None
    invalid_reason: str | None = None
    robustness_g: float | None = None
    hold_slip_m: float | None = None
    hold_rotation_rad: float | None = None
    min_finger_force_n: float | None = None


@dataclass
class ValidityResult:
    """The validity verdict of an episode: the row's validity columns."""

    valid: bool = False
    invalid_reason: str = ""
    message: str = ""
    measure: ValidityMeasure = field(default_factory=ValidityMeasure)


@dataclass
class PickOutcome:
    """What the execution measured and concluded."""

    success: bool = False
    failure_reason: FailureReason = ""
    message: str = ""
    sim_time_s: float = 0.0
    sim_steps: int = 0
    control_steps: int = 0
    finger_force_left_n: float = float("nan")  # after closing
    finger_force_right_n: float = float("nan")
    lift_height_m: float = float("nan")
    slip_m: float = float("nan")
    max_joint_vel: float = 0.0  # peak over the execution
    max_object_vel: float = 0.0  # peak object speed over the execution
    verdict_joint_speed: float = float("nan")  # at the verdict (the reference's check)
    verdict_object_speed: float = float("nan")
    verdict_forces: tuple[float, float] = (float("nan"), float("nan"))
    tcp_grasp_error_m: float = float("nan")
    object_z_before: float = float("nan")
    object_z_after: float = float("nan")
    contact_during_close: bool = False
    # The object's pose in the TCP frame when the closing window ended (the slip reference).
    T_tcp_object_closed: np.ndarray | None = None
    collisions: list[str] = field(default_factory=list)
    collision_pair: tuple[str, str] | None = None  # bodies of the first strict collision
    failure_phase: str = ""  # the command (function:target) running when the failure was set
    trace: ExecutionTrace | None = None
    # Deepest robot geom below the table top during the motion (m), measured geometrically.
    table_penetration_m: float = 0.0
    validity: ValidityResult | None = None  # None when the phase is off
    validity_time_s: float = 0.0  # wall time of the validity phase
    # A handover's second pick: the opened first gripper's larger finger force on the object
    # after the release (harness.pick.release); NaN for every other pick.
    first_gripper_force_n: float = math.nan
