"""One declaration per verdict term: its name, failure reason, phases, measurement, threshold and
the semantics that use it (the table ``TERMS``), like mjlab's termination terms.

A term is checked in one or more phases of a pick (``Phase``):

- ``closing`` (strict): when the closing command ends, from the two finger forces;
- ``reference``: the reference ``is_success``, when the command list empties (``PickOutcome``);
- ``motion`` (strict): after the motion, from its collisions (``PickOutcome``);
- ``validity``: the validity phase after the reference verdict (``ValidityMeasure``), under
  ``reference`` with ``validity: on`` and always under ``strict`` (its verdict); a validity
  term's name is the row's ``invalid_reason``;
- ``hold_end`` (strict): at the end of the validity hold (``ValidityMeasure``).

Within a phase the terms are checked in table order and the first that fails is the cause
(``harness.pick.verdict``). Everything else derives from this table: the term lists of
``harness.pick.verdict``, ``VALIDITY_REASONS`` (``harness.row``), the row columns a recording's
verdict document shows (``harness.viz.episode_layers``). A light module (no MuJoCo): the row
schema and the report import it.

Adding a term: one ``TermCfg`` here (its checks read fields of the phase's measurement; a new
measurement is a field of ``PickOutcome`` / ``ValidityMeasure`` and, to be in the row, of
``harness.row.EpisodeRow`` and a record of ``harness.episode.records``), and, for a validity
term, a test in tests/test_validity.py that makes it the first cause.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

from harness.failures import FailureReason

if TYPE_CHECKING:
    from harness.config import PickConfig

Phase = Literal["closing", "reference", "motion", "validity", "hold_end"]

# process_valid bound (rad/s and m/s mixed, as in the reference)
MAX_VELOCITY = 5.0
# Validity: a robot geom deeper than this inside the table top makes the grasp non-physical (m).
MAX_TABLE_PENETRATION = 0.002
# Validity: the lowest tug level (x g x mass) the grasp must survive in every direction.
MIN_ROBUSTNESS_G = 0.5
# The tug levels (x g x mass) of the validity phase; robustness_g is 0 or one of them.
ROBUSTNESS_LEVELS_G: tuple[float, ...] = (0.5, 1.0, 2.0, 4.0)
# The validity cause of an episode that ended before its verdict (no candidate, no plan,
# timeout, instability, error, a strict stop): the phase did not run.
NOT_RUN = "not_run"


@dataclass(frozen=True)
class TermCheck:
    """How a term is checked in one phase: ``passed(pick, measurement)`` and the failure
    ``message``; ``reason`` overrides the term's failure reason from the measurement."""

    phase: Phase
    passed: Callable[[PickConfig, Any], bool]
    message: Callable[[PickConfig, Any], str]
    reason: Callable[[Any], FailureReason] | None = None


@dataclass(frozen=True)
class TermCfg:
    """One verdict term.

    ``reason``: the failure reason when it fails; ``measured``: what its checks read (fields of
    the phase's measurement); ``columns``: the row columns that show it; ``threshold``: the
    ``PickConfig`` key or module constant it compares against; ``semantics``: where it applies
    (``validity``: the validity phase under either semantics)."""

    name: str
    reason: FailureReason
    measured: str
    columns: tuple[str, ...]
    threshold: str
    semantics: tuple[str, ...]
    checks: tuple[TermCheck, ...]


def _closes(pick: PickConfig) -> bool:
    return pick.final_gripper_state == -1


def _speeds_valid(pick: PickConfig, joint_speed: float, object_speed: float) -> bool:
    """``process_valid``: max |joint velocity| and max |object velocity component| < 5."""
    return not pick.process_valid or (joint_speed < MAX_VELOCITY and object_speed < MAX_VELOCITY)


TERMS: tuple[TermCfg, ...] = (
    TermCfg(
        "finger_touches_object", "no_contact", "verdict_forces",
        ("finger_force_left_n", "finger_force_right_n"), "final_gripper_state",
        ("reference",),
        (TermCheck(
            "reference",
            lambda pick, out: not (_closes(pick) and not max(out.verdict_forces) > 0.0),
            lambda pick, out: "no finger touches the object when the command list empties",
            lambda out: "dropped" if out.contact_during_close else "no_contact",
        ),),
    ),
    TermCfg(
        "velocity_valid", "velocity_invalid",
        "verdict_joint_speed, verdict_object_speed (reference); joint_speed, object_speed "
        "(strict, end of the hold)",
        (), "process_valid, MAX_VELOCITY", ("reference", "strict"),
        (
            TermCheck(
                "reference",
                lambda pick, out: _speeds_valid(
                    pick, out.verdict_joint_speed, out.verdict_object_speed
                ),
                lambda pick, out: f"max joint speed {out.verdict_joint_speed:.2f}, max object "
                f"velocity {out.verdict_object_speed:.2f} (bound {MAX_VELOCITY})",
            ),
            TermCheck(
                "hold_end",
                lambda pick, v: _speeds_valid(pick, v.joint_speed, v.object_speed),
                lambda pick, v: "velocities above the bound after the hold",
            ),
        ),
    ),
    TermCfg(
        "lifted", "lift_below_threshold", "lift_height_m", ("lift_height_m",), "lift_th",
        ("reference",),
        (TermCheck(
            "reference",
            lambda pick, out: not (pick.lift_th > 0 and not out.lift_height_m > pick.lift_th),
            lambda pick, out: f"lifted {out.lift_height_m * 1e3:.1f} mm, threshold "
            f"{pick.lift_th * 1e3:.1f} mm",
        ),),
    ),
    TermCfg(
        "collision", "collision", "collisions", (), "", ("strict",),
        (TermCheck(
            "motion",
            lambda pick, out: not out.collisions,
            lambda pick, out: f"robot collided: {out.collisions[0] if out.collisions else ''}",
        ),),
    ),
    TermCfg(
        "table_penetration", "collision", "table_penetration_m", ("table_penetration_m",),
        "MAX_TABLE_PENETRATION", ("validity",),
        (TermCheck(
            "validity",
            lambda pick, v: v.table_penetration_m < MAX_TABLE_PENETRATION,
            lambda pick, v: f"a robot geom went {v.table_penetration_m * 1e3:.1f} mm into the "
            f"table (bound {MAX_TABLE_PENETRATION * 1e3:.0f} mm)",
        ),),
    ),
    TermCfg(
        "not_lifted", "lift_below_threshold", "lift_height_m (after the hold)", (), "lift_th",
        ("validity",),
        (TermCheck(
            "validity",
            lambda pick, v: v.lift_height_m > pick.lift_th,
            lambda pick, v: f"lifted {v.lift_height_m * 1e3:.1f} mm after the hold, threshold "
            f"{pick.lift_th * 1e3:.1f} mm",
        ),),
    ),
    TermCfg(
        "one_finger", "no_contact",
        "the two finger forces (closing); min_finger_force_n (validity)",
        ("min_finger_force_n",), "min_finger_force", ("strict", "validity"),
        (
            TermCheck(
                "closing",
                lambda pick, forces: not (_closes(pick) and min(forces) < pick.min_finger_force),
                lambda pick, forces: f"finger forces {forces[0]:.2f} / {forces[1]:.2f} N after "
                f"closing, below {pick.min_finger_force} N",
            ),
            TermCheck(
                "validity",
                lambda pick, v: not (
                    _closes(pick) and not v.min_finger_force_n >= pick.min_finger_force
                ),
                # min_finger_force_n is the weaker finger after the hold, not at the closing:
                # a slow gripper may close during the lift (issue 22)
                lambda pick, v: f"finger forces {v.finger_forces[0]:.2f} / "
                f"{v.finger_forces[1]:.2f} N after the hold (after closing "
                f"{v.closing_forces[0]:.2f} / {v.closing_forces[1]:.2f} N): one below "
                f"{pick.min_finger_force} N",
            ),
        ),
    ),
    TermCfg(
        "slipped_in_hold", "dropped", "hold_slip_m, hold_rotation_rad (closing to hold end)",
        ("hold_slip_m", "hold_rotation_rad"), "max_slip, max_slip_rotation",
        ("validity",),
        (TermCheck(
            "validity",
            # a rotation not measured (NaN: the phase never closed on it) does not fail
            lambda pick, v: v.hold_slip_m <= pick.max_slip
            and not v.hold_rotation_rad > pick.max_slip_rotation,
            lambda pick, v: f"the object slipped {v.hold_slip_m * 1e3:.1f} mm and turned "
            f"{math.degrees(v.hold_rotation_rad):.1f} deg in the hand from the closing to the "
            f"end of the hold (bounds {pick.max_slip * 1e3:.1f} mm, "
            f"{math.degrees(pick.max_slip_rotation):.1f} deg)",
        ),),
    ),
    TermCfg(
        "lost_in_tug", "dropped", "robustness_g", ("robustness_g",), "MIN_ROBUSTNESS_G",
        ("validity",),
        (TermCheck(
            "validity",
            lambda pick, v: v.robustness_g >= MIN_ROBUSTNESS_G,
            lambda pick, v: f"lost in the tug: {v.tug_message}",
        ),),
    ),
    TermCfg(
        # A handover's second pick (harness.pick.release; chosen, no public source): the
        # opened first gripper must not still press on the object. NaN (no handover) passes.
        "first_gripper_contact", "dropped", "first_gripper_force_n (after the release)",
        ("first_gripper_force_n",), "max_first_gripper_force", ("validity",),
        (TermCheck(
            "validity",
            lambda pick, v: not v.first_gripper_force_n > pick.max_first_gripper_force,
            lambda pick, v: f"the opened first gripper still presses on the object "
            f"({v.first_gripper_force_n:.2f} N) after the release: no handover",
        ),),
    ),
)  # fmt: skip


def phase_checks(phase: Phase) -> tuple[tuple[TermCfg, TermCheck], ...]:
    """The terms checked in ``phase``, in table order, each with its check there."""
    return tuple((term, check) for term in TERMS for check in term.checks if check.phase == phase)


# The validity causes in the order the phase meets them (first cause wins), then ``not_run``.
VALIDITY_REASONS: tuple[str, ...] = (
    *(term.name for term, _ in phase_checks("validity")),
    NOT_RUN,
)


def term_columns() -> tuple[str, ...]:
    """The row columns that show the terms' measurements, in table order, each once."""
    return tuple(dict.fromkeys(column for term in TERMS for column in term.columns))
