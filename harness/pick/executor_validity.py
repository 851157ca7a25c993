"""The end of a CPU pick execution: the validity phase on the executor, then its verdict.

Split from ``harness.pick.executor`` (the control loop): after the reference verdict the executor
hosts ``harness.pick.validity.ValidityPhase`` (it is its ``PhaseHost``) and this module turns what
the phase measured into the row's ``ValidityResult`` with the one set of verdict terms
(``harness.pick.verdict``), and, under strict, into the episode's verdict.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np

from harness.config import PickConfig
from harness.pick.outcome import PickOutcome, ValidityMeasure, ValidityResult
from harness.pick.semantics import Semantics
from harness.pick.validity import PhaseHost, ValidityPhase
from harness.pick.verdict import (
    MAX_TABLE_PENETRATION,
    VerdictTerm,
    first_failure,
    validity_terms,
)


class ValidityHost(PhaseHost, Protocol):
    """What the validity phase's end needs of the executor that ran the pick
    (``harness.pick.executor.PickExecutor``; a protocol, so this module does not import it)."""

    out: PickOutcome
    pick: PickConfig
    semantics: Semantics
    failed_term: str
    post: str | None
    object_init_position: np.ndarray

    def judge(self, terms: tuple[VerdictTerm, ...]) -> bool: ...


def stopped_validity(measure: ValidityMeasure, failed_term: str, message: str) -> ValidityResult:
    """The validity result of an episode stopped before its verdict: only the motion's facts
    count (too deep into the table, or strict's early ``one_finger``), else ``not_run``."""
    too_deep = not measure.table_penetration_m < MAX_TABLE_PENETRATION
    reason = "table_penetration" if too_deep else ""
    reason = reason or (failed_term if failed_term == "one_finger" else "")
    return ValidityResult(False, reason or "not_run", message, measure)


def judged_validity(pick: PickConfig, measure: ValidityMeasure) -> ValidityResult:
    """The validity verdict on a measured phase (``validity_terms``)."""
    failed = first_failure(validity_terms(pick, measure))
    return ValidityResult(
        failed is None, failed.name if failed else "", failed.message if failed else "", measure
    )


def run_validity_phase(executor: ValidityHost, verdict_reached: bool) -> None:
    """After the verdict: the validity phase and its verdict (strict's success); the command
    list's columns (steps, peak speeds) stay those of the list."""
    out = executor.out
    measure = ValidityMeasure(
        table_penetration_m=out.table_penetration_m,
        closing_forces=(out.finger_force_left_n, out.finger_force_right_n),
    )
    if not verdict_reached:
        out.validity = stopped_validity(measure, executor.failed_term, out.message)
        return
    kept = (out.sim_steps, out.max_joint_vel, out.max_object_vel)
    executor.post = "validity:finish"
    object_init_z = float(executor.object_init_position[2])
    ValidityPhase(executor, executor.pick.hold_time, object_init_z).run(measure)
    measure.table_penetration_m = out.table_penetration_m
    out.validity = judged_validity(executor.pick, measure)
    failed_name = out.validity.invalid_reason
    executor.event(
        f"validity: {failed_name or 'valid'}, robustness "
        f"{measure.robustness_g:g} g, hold slip {measure.hold_slip_m * 1e3:.2f} mm / "
        f"{math.degrees(measure.hold_rotation_rad):.1f} deg"
    )
    if executor.semantics.hold_after_list:  # strict: this is the verdict
        out.slip_m, out.lift_height_m = measure.hold_slip_m, measure.lift_height_m
        out.verdict_forces = measure.finger_forces
        executor.judge(executor.semantics.verdict_terms(executor.pick, out))
        out.success = not out.failure_reason
        executor.event(f"verdict: {'success' if out.success else out.failure_reason}")
    out.sim_steps, out.max_joint_vel, out.max_object_vel = kept
