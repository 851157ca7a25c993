"""What an episode's recording, video and report tile say first: its outcome class and a
headline with both verdicts (the reference's and the validity phase's), and its caption.

A reference success whose finger went through the table is never headed just "SUCCESS": the
headline is ``REFERENCE SUCCESS · INVALID: table_penetration (31.2 mm into the table)``.
"""

from __future__ import annotations

import math
from typing import Any

# Outcome kinds, for colours: the grasp really works, the reference says success but the grasp
# is not physically valid, the reference says failure.
VALID, INVALID, FAILED = "valid", "invalid", "failed"
KIND_COLORS: dict[str, tuple[int, int, int]] = {
    VALID: (40, 160, 70),
    INVALID: (230, 140, 20),
    FAILED: (210, 40, 40),
}


def _text(row: Any, key: str) -> str:
    value = row.get(key) if hasattr(row, "get") else None
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    return str(value)


def _number(row: Any, key: str) -> float:
    try:
        return float(row.get(key))
    except (TypeError, ValueError):
        return math.nan


def outcome_kind(row: Any) -> str:
    """valid, invalid (a reference success judged not valid) or failed."""
    if not bool(row.get("success")):
        return FAILED
    reason = _text(row, "invalid_reason")
    return INVALID if reason and reason != "not_run" and not bool(row.get("valid")) else VALID


def outcome_class(row: Any) -> str:
    """``success_valid``, ``success_invalid:<reason>`` or ``failure:<reason>``: the classes the
    demo records and films one of each."""
    kind = outcome_kind(row)
    if kind == FAILED:
        return f"failure:{_text(row, 'failure_reason') or 'unknown'}"
    if kind == INVALID:
        return f"success_invalid:{_text(row, 'invalid_reason')}"
    return "success_valid"


def _why_invalid(row: Any) -> str:
    reason = _text(row, "invalid_reason")
    if reason == "table_penetration":
        depth = _number(row, "table_penetration_m")
        return f" ({depth * 1e3:.1f} mm)" if math.isfinite(depth) else ""
    if reason in ("slipped_in_hold",):
        slip = _number(row, "hold_slip_m")
        return f" ({slip * 1e3:.1f} mm slip)" if math.isfinite(slip) else ""
    if reason == "one_finger":
        force = _number(row, "min_finger_force_n")
        return f" (weaker finger {force:.2f} N)" if math.isfinite(force) else ""
    return ""


def headline(row: Any) -> str:
    """The outcome with both verdicts and where it failed, in one line."""
    kind = outcome_kind(row)
    if kind == VALID:
        judged = _text(row, "invalid_reason") == "" and bool(row.get("valid"))
        return "SUCCESS · VALID" if judged else "SUCCESS (validity not judged)"
    if kind == INVALID:
        reason = _text(row, "invalid_reason")
        return f"REFERENCE SUCCESS · INVALID: {reason}{_why_invalid(row)}"
    text = f"FAILURE: {_text(row, 'failure_reason')}"
    stage = _text(row, "failure_stage")
    if stage:
        text += f" at {stage}"
    a, b = _text(row, "collision_a"), _text(row, "collision_b")
    if a or b:
        text += f" ({a} hits {b})"
    return text


def caption(row: Any) -> str:
    """robot / arm · object · seed: what the episode was."""
    return (
        f"{_text(row, 'robot')} {_text(row, 'arm')} arm · {_text(row, 'object')} · "
        f"seed {_text(row, 'seed')}"
    )
