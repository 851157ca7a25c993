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

Each term is declared once, in ``harness.pick.terms.TERMS`` (name, reason, phases, measurement,
threshold, semantics); the lists here are that table's checks of one phase. The terms read only
the measurements in ``PickOutcome`` / ``ValidityMeasure`` (and the forces at closing), so they
can be checked without a simulation.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from harness.config import PickConfig
from harness.failures import FailureReason
from harness.pick.outcome import PickOutcome, ValidityMeasure
from harness.pick.terms import (
    MAX_TABLE_PENETRATION,
    MAX_VELOCITY,
    MIN_ROBUSTNESS_G,
    Phase,
    phase_checks,
)

__all__ = [
    "MAX_TABLE_PENETRATION",
    "MAX_VELOCITY",
    "MIN_ROBUSTNESS_G",
    "VerdictTerm",
    "closing_terms",
    "first_failure",
    "reference_terms",
    "strict_terms",
    "validity_terms",
]


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


def phase_terms(phase: Phase, pick: PickConfig, measurement: Any) -> tuple[VerdictTerm, ...]:
    """The terms of ``phase`` (``harness.pick.terms.TERMS`` order) checked on ``measurement``."""
    return tuple(
        VerdictTerm(
            term.name,
            check.reason(measurement) if check.reason is not None else term.reason,
            check.passed(pick, measurement),
            check.message(pick, measurement),
        )
        for term, check in phase_checks(phase)
    )


def closing_terms(pick: PickConfig, forces: tuple[float, float]) -> tuple[VerdictTerm, ...]:
    """Strict, when the closing ends: both fingers carry ``min_finger_force`` (closing only)."""
    return phase_terms("closing", pick, forces)


def reference_terms(pick: PickConfig, out: PickOutcome) -> tuple[VerdictTerm, ...]:
    """The reference ``is_success``, on the measurements taken when the list empties."""
    return phase_terms("reference", pick, out)


def validity_terms(pick: PickConfig, v: ValidityMeasure) -> tuple[VerdictTerm, ...]:
    """The validity verdict (``harness.pick.validity`` measures it), in the order the phase meets
    its causes: the motion, the lift, the grasp at the lifted pose, the hold, the tug.

    Each term's name is the row's ``invalid_reason`` and its reason the failure strict reports
    (strict's success is this verdict)."""
    return phase_terms("validity", pick, v)


def strict_terms(pick: PickConfig, out: PickOutcome) -> tuple[VerdictTerm, ...]:
    """Strict, after the validity phase: no collision during the motion, the validity verdict
    (``validity_terms``), and the reference's velocity bound at the end of the hold."""
    assert out.validity is not None
    v = out.validity.measure
    return (
        *phase_terms("motion", pick, out),
        *validity_terms(pick, v),
        *phase_terms("hold_end", pick, v),
    )
