"""The success checks of a pick, as named terms: ``(name, reason, passed, message)``.

Like ManiSkill3's ``evaluate()`` returning named booleans, each check is one ``VerdictTerm``;
the executor fails the episode with the first term that did not pass (the terms are in
pipeline order, so the first cause wins). Which terms apply is the semantics' call
(``harness.pick.semantics``):

- ``reference``: evaluated once, at the step the list becomes empty: at least one finger touches
  the object with force > 0 (when the final command closes), max |joint velocity| < 5 and max
  |object linear velocity component| < 5 (``process_valid``), and lift > ``lift_th`` measured from
  the object's position before settling (``obj_init_trans``).
- ``strict``: both fingers carry >= ``min_finger_force`` N when the closing ends; no robot
  collision with the environment during the motion; after the lift the trajectory finishes, the
  object comes to rest, then is held for ``hold_time`` s with slip (object motion relative to the
  TCP) below ``max_slip``; both fingers still carry the force; lift > ``lift_th``.

The terms read only the measurements in ``PickOutcome`` (and the forces at closing), so they
can be checked without a simulation; the collision, rest and timing parts of strict are the
executor's state machine.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from harness.config import PickConfig
from harness.failures import FailureReason
from harness.pick.outcome import PickOutcome

MAX_VELOCITY = 5.0  # process_valid bound (rad/s and m/s mixed, as in the reference)


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
            "fingers_closed_on_object",
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


def strict_hold_terms(pick: PickConfig, out: PickOutcome) -> tuple[VerdictTerm, ...]:
    """Strict, after the hold: forces, slip, velocities and lift, on the measurements then."""
    forces = out.verdict_forces
    return (
        VerdictTerm(
            "fingers_hold_object",
            "dropped",
            not (pick.final_gripper_state == -1 and min(forces) < pick.min_finger_force),
            f"finger forces {forces[0]:.2f} / {forces[1]:.2f} N after the hold, below "
            f"{pick.min_finger_force} N",
        ),
        VerdictTerm(
            "no_slip",
            "dropped",
            not out.slip_m > pick.max_slip,
            f"the object slipped {out.slip_m * 1e3:.1f} mm in the hold",
        ),
        VerdictTerm(
            "velocity_valid",
            "velocity_invalid",
            velocity_valid(pick, out),
            "velocities above the bound after the hold",
        ),
        VerdictTerm(
            "lifted",
            "lift_below_threshold",
            out.lift_height_m > pick.lift_th,
            f"lifted {out.lift_height_m * 1e3:.1f} mm, threshold {pick.lift_th * 1e3:.1f} mm",
        ),
    )
