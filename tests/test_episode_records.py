"""The stages' typed records (harness/episode/records.py) are row columns, merged in one place.

Every field of every record type is a column of the ``EpisodeRow`` schema with the same value
type, so a stage cannot invent a column the store, the CSV and the report do not know; and
``merge_records`` writes a record's fields in order, leaving the row's value where a field is
``None`` (not measured).
"""

from __future__ import annotations

import math
import typing
from dataclasses import fields

import pytest

from harness.episode.records import (
    ROW_RECORDS,
    ChoiceColumns,
    EndColumns,
    merge_records,
    record_columns,
)
from harness.pick.outcome import ValidityColumns
from harness.row import SCHEMA, empty_row

PY_TYPES = {"str": str, "int": int, "float": float, "bool": bool}


@pytest.mark.parametrize("record", ROW_RECORDS, ids=lambda r: r.__name__)
def test_every_record_field_is_a_row_column_of_its_type(record: type) -> None:
    hints = typing.get_type_hints(record)
    for field in fields(record):
        assert field.name in SCHEMA, f"{record.__name__}.{field.name} is not an EpisodeRow column"
        kinds = set(typing.get_args(hints[field.name]) or (hints[field.name],)) - {type(None)}
        assert kinds == {PY_TYPES[SCHEMA[field.name].dtype]}, (
            f"{record.__name__}.{field.name}: {kinds} but the row column is "
            f"{SCHEMA[field.name].dtype}"
        )


def test_each_column_has_one_record_type() -> None:
    """One record type per column: a column has one writer (the pipeline's ``not_run``
    rule re-uses ``ValidityColumns``, the same record)."""
    owner: dict[str, str] = {}
    for record in ROW_RECORDS:
        for field in fields(record):
            assert field.name not in owner, (
                f"{field.name} in both {owner[field.name]} and {record.__name__}"
            )
            owner[field.name] = record.__name__


def test_merge_writes_in_order_and_skips_unmeasured_fields() -> None:
    row = empty_row()
    row["robustness_g"] = 2.0
    merge_records(
        row,
        [
            ChoiceColumns(chosen_index=7, chosen_score=0.5, approach_angle_deg=12.0),
            ValidityColumns(0.001),  # validity off: only the penetration is measured
            EndColumns("dropped", "lost it", success=False),
            EndColumns("", "", success=True),  # a later record wins
        ],
    )
    assert (row["chosen_index"], row["chosen_score"], row["approach_angle_deg"]) == (7, 0.5, 12.0)
    assert row["table_penetration_m"] == 0.001
    assert row["robustness_g"] == 2.0 and row["invalid_reason"] == "" and row["valid"] is False
    assert (row["failure_reason"], row["error_message"], row["success"]) == ("", "", True)
    assert record_columns(
        ValidityColumns(math.nan, valid=False, invalid_reason="not_run")
    ).keys() == {
        "table_penetration_m",
        "valid",
        "invalid_reason",
    }
