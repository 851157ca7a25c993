"""The success checks of a pick, as named terms: ``(name, reason, passed, message)``.

Like ManiSkill3's ``evaluate()`` returning named booleans, each check is one ``VerdictTerm``;
the executor fails the episode with the first term that did not pass (the terms are in
pipeline order, so the first cause wins). Which terms apply is the semantics' call
(``harness.pick.semantics``):

- ``reference``: evaluated once, at the step the list becomes empty: at least one finger touches
  the object with force > 0 (when the final command closes), max |joint velocity| < 5 and max
  |object linear velocity component| < 5 (``process_valid``), and lift > ``lift_th`` measured from
  the object's position before settling (``obj_init_trans``).
- validity (``validity_terms``, after the reference verdict, measured by
  ``harness.pick.validity``): no robot geom more than 2 mm inside the table top during the
  motion; the object lifted more than ``lift_th``; both fingers carry >= ``min_finger_force`` N
  after the hold (not when the closing ends: a slow gripper may close during the lift); the
  object's drift relative to the TCP from the closing to the end of a ``hold_time`` s hold under
  ``max_slip`` and ``max_slip_rotation``; the tug survived at 0.5 g in every direction. A
  term's name is the row's ``invalid_reason``.
- ``strict``: both fingers carry >= ``min_finger_force`` N when the closing ends (the same
  ``one_finger`` check, early); then no robot collision with the environment during the motion,
  the validity terms, and the velocity bound after the hold (``strict_terms``): strict's success
  IS the validity verdict, its failure reasons the validity causes' (``table_penetration`` ->
  ``collision``, ``not_lifted`` -> ``lift_below_threshold``, ``one_finger`` -> ``no_contact``,
  ``slipped_in_hold`` and ``lost_in_tug`` -> ``dropped``).

The terms read only the measurements in ``PickOutcome`` / ``ValidityMeasure`` (and the forces at
closing), so they can be checked without a simulation.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

from harness.config import PickConfig
from harness.failures import FailureReason
from harness.pick.outcome import PickOutcome, ValidityMeasure

MAX_VELOCITY = 5.0  # process_valid bound (rad/s and m/s mixed, as in the reference)
# Validity: a robot geom deeper than this inside the table top makes the grasp non-physical (m).
MAX_TABLE_PENETRATION = 0.002
# Validity: the lowest tug level (x g x mass) the grasp must survive in every direction.
MIN_ROBUSTNESS_G = 0.5


@dataclass(frozen=True)
class VerdictTerm:
    """One named check: when it did not pass, the episode fails with ``reason``, ``message``."""

    name: str
    reason: FailureReason
    passed: bool
    message: str


def first_failure(terms: Iterable[VerdictTerm]) -> VerdictTerm | None:
    """The first term that did not pass, or None."""
    return next((term for term in terms if not term.passed), None)


def velocity_valid(pick: PickConfig, out: PickOutcome) -> bool:
    """``process_valid``: max |joint velocity| and max |object velocity component| < 5."""
    return not pick.process_valid or (
        out.verdict_joint_speed < MAX_VELOCITY and out.verdict_object_speed < MAX_VELOCITY
    )


def closing_terms(pick: PickConfig, forces: tuple[float, float]) -> tuple[VerdictTerm, ...]:
    """Strict, when the closing ends: both fingers carry ``min_finger_force`` (closing only)."""
    closes = pick.final_gripper_state == -1
    return (
        VerdictTerm(
            "one_finger",
            "no_contact",
            not (closes and min(forces) < pick.min_finger_force),
            f"finger forces {forces[0]:.2f} / {forces[1]:.2f} N after closing, "
            f"below {pick.min_finger_force} N",
        ),
    )


def reference_terms(pick: PickConfig, out: PickOutcome) -> tuple[VerdictTerm, ...]:
    """The reference ``is_success``, on the measurements taken when the list empties."""
    forces = out.verdict_forces
    return (
        VerdictTerm(
            "finger_touches_object",
            "dropped" if out.contact_during_close else "no_contact",
            not (pick.final_gripper_state == -1 and not max(forces) > 0.0),
            "no finger touches the object when the command list empties",
        ),
        VerdictTerm(
            "velocity_valid",
            "velocity_invalid",
            velocity_valid(pick, out),
            f"max joint speed {out.verdict_joint_speed:.2f}, max object velocity "
            f"{out.verdict_object_speed:.2f} (bound {MAX_VELOCITY})",
        ),
        VerdictTerm(
            "lifted",
            "lift_below_threshold",
            not (pick.lift_th > 0 and not out.lift_height_m > pick.lift_th),
            f"lifted {out.lift_height_m * 1e3:.1f} mm, threshold {pick.lift_th * 1e3:.1f} mm",
        ),
    )


def validity_terms(pick: PickConfig, v: ValidityMeasure) -> tuple[VerdictTerm, ...]:
    """The validity verdict (``harness.pick.validity`` measures it), in the order the phase meets
    its causes: the motion, the lift, the grasp at the lifted pose, the hold, the tug.

    Each term's name is the row's ``invalid_reason`` and its reason the failure strict reports
    (strict's success is this verdict)."""
    closes = pick.final_gripper_state == -1
    closing, held = v.closing_forces, v.finger_forces
    return (
        VerdictTerm(
            "table_penetration",
            "collision",
            v.table_penetration_m < MAX_TABLE_PENETRATION,
            f"a robot geom went {v.table_penetration_m * 1e3:.1f} mm into the table "
            f"(bound {MAX_TABLE_PENETRATION * 1e3:.0f} mm)",
        ),
        VerdictTerm(
            "not_lifted",
            "lift_below_threshold",
            v.lift_height_m > pick.lift_th,
            f"lifted {v.lift_height_m * 1e3:.1f} mm after the hold, threshold "
            f"{pick.lift_th * 1e3:.1f} mm",
        ),
        VerdictTerm(
            "one_finger",
            "no_contact",
            not (closes and not v.min_finger_force_n >= pick.min_finger_force),
            f"finger forces {held[0]:.2f} / {held[1]:.2f} N after the hold (after closing "
            f"{closing[0]:.2f} / {closing[1]:.2f} N): one below {pick.min_finger_force} N",
        ),
        VerdictTerm(
            "slipped_in_hold",
            "dropped",
            # a rotation not measured (NaN: the phase never closed on it) does not fail
            v.hold_slip_m <= pick.max_slip and not v.hold_rotation_rad > pick.max_slip_rotation,
            f"the object slipped {v.hold_slip_m * 1e3:.1f} mm and turned "
            f"{math.degrees(v.hold_rotation_rad):.1f} deg in the hand from the closing to the end "
            f"of the hold (bounds {pick.max_slip * 1e3:.1f} mm, "
            f"{math.degrees(pick.max_slip_rotation):.1f} deg)",
        ),
        VerdictTerm(
            "lost_in_tug",
            "dropped",
            v.robustness_g >= MIN_ROBUSTNESS_G,
            f"lost in the tug: {v.tug_message}",
        ),
    )


def strict_terms(pick: PickConfig, out: PickOutcome) -> tuple[VerdictTerm, ...]:
    """Strict, after the validity phase: no collision during the motion, the validity verdict
    (``validity_terms``), and the reference's velocity bound at the end of the hold."""
    assert out.validity is not None
    v = out.validity.measure
    return (
        VerdictTerm(
            "collision",
            "collision",
            not out.collisions,
            f"robot collided: {out.collisions[0] if out.collisions else ''}",
        ),
        *validity_terms(pick, v),
        VerdictTerm(
            "velocity_valid",
            "velocity_invalid",
            not pick.process_valid
            or (v.joint_speed < MAX_VELOCITY and v.object_speed < MAX_VELOCITY),
            "velocities above the bound after the hold",
        ),
    )
