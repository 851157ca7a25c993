"""The verdict terms are declared once (harness/pick/terms.py) and everything else derives from it.

The table's entries are consistent (unique names, known phases per semantics, thresholds that are
``PickConfig`` keys or the module's constants, columns of the row schema), and the term lists,
``VALIDITY_REASONS``, the recording's row keys and the tune's harness-only keys come from the
declarations. The checks' behaviour is tested on numbers in test_pick.py and test_validity.py.
"""

from __future__ import annotations

import harness.pick.terms as terms_module
from harness.config import PickConfig
from harness.config.pick import harness_only_keys
from harness.pick.outcome import PickOutcome, ValidityMeasure, ValidityResult
from harness.pick.terms import NOT_RUN, TERMS, VALIDITY_REASONS, phase_checks, term_columns
from harness.pick.verdict import closing_terms, reference_terms, strict_terms, validity_terms
from harness.row import SCHEMA
from harness.tuning.blocks import OWN_PICK_KEYS
from harness.viz.episode_layers import ROW_KEYS

# Which semantics check a phase.
PHASE_SEMANTICS = {
    "closing": "strict",
    "reference": "reference",
    "motion": "strict",
    "validity": "validity",
    "hold_end": "strict",
}


def test_one_declaration_per_term_and_a_consistent_table() -> None:
    names = [term.name for term in TERMS]
    assert len(names) == len(set(names)), f"a term declared twice: {names}"
    for term in TERMS:
        assert term.checks, term.name
        phases = [check.phase for check in term.checks]
        assert len(phases) == len(set(phases)), f"{term.name} checked twice in one phase"
        assert {PHASE_SEMANTICS[p] for p in phases} == set(term.semantics), term.name
        for column in term.columns:
            assert column in SCHEMA, f"{term.name}: {column} is not a row column"
        for threshold in filter(None, (t.strip() for t in term.threshold.split(","))):
            assert threshold in PickConfig.model_fields or hasattr(terms_module, threshold), (
                f"{term.name}: threshold {threshold!r} is neither a pick key nor a constant"
            )


def test_term_lists_and_validity_reasons_follow_the_table() -> None:
    pick = PickConfig()
    out = PickOutcome(verdict_forces=(1.0, 1.0), lift_height_m=0.1)
    measure = ValidityMeasure(
        ran=True, table_penetration_m=0.0, lift_height_m=0.1, closing_forces=(1.0, 1.0),
        finger_forces=(1.0, 1.0), hold_slip_m=0.0, robustness_g=4.0, object_speed=0.0,
        joint_speed=0.0,
    )  # fmt: skip
    out.validity = ValidityResult(valid=True, measure=measure)
    validity = [t.name for t in validity_terms(pick, measure)]
    assert validity == [term.name for term, _ in phase_checks("validity")]
    assert (*validity, NOT_RUN) == VALIDITY_REASONS
    assert [t.name for t in reference_terms(pick, out)] == [
        term.name for term, _ in phase_checks("reference")
    ]
    assert [t.name for t in closing_terms(pick, (1.0, 1.0))] == ["one_finger"]
    strict = [t.name for t in strict_terms(pick, out)]
    assert strict == ["collision", *validity, "velocity_valid"]
    # one_finger is one declaration checked in two phases
    assert [term.name for term in TERMS].count("one_finger") == 1
    assert all(t.passed for t in strict_terms(pick, out))


def test_the_recording_shows_every_column_a_term_reads() -> None:
    assert set(term_columns()) <= set(ROW_KEYS)
    assert {"valid", "invalid_reason"} <= set(ROW_KEYS)


def test_harness_only_pick_keys_come_from_the_model() -> None:
    assert harness_only_keys() == OWN_PICK_KEYS
    assert {"semantics", "approach_filter", "validity", "min_finger_force", "max_slip"} <= (
        OWN_PICK_KEYS
    )
    # the reference's own keys are not marked
    assert not {"lift_th", "filter_x_dir", "pre_grasp_offset", "process_valid"} & OWN_PICK_KEYS
    assert set(PickConfig.model_fields) >= OWN_PICK_KEYS
