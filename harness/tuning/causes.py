"""Why nothing helps: the dominant failure cause of a unit's race rows, and the physical fact
behind it, for the "no setting helps" decision.

A failed row's cause is its ``failure_reason`` at its ``failure_stage`` (``plan_failed at
plan:lift``); a row that succeeded by the reference but failed the objective ``valid`` is its
``invalid_reason`` (``table_penetration``). The fact per cause is what the cause measures
(docs/semantics.md's verdict tables and harness/failures.py), said in physical terms; a filter
only chooses among the same grasps, so when one cause dominates every setting no filter removes it.
"""

from __future__ import annotations

from collections import Counter
from typing import Any

# What each cause means physically (docs/semantics.md; harness/failures.py's taxonomy).
FACTS: dict[str, str] = {
    "filter_empty": "the filter keeps none of the object's grasps",
    "no_feasible_candidate": (
        "no kept grasp passes the feasibility tests: its poses are beyond the arm's reach or "
        "collide at the pre-grasp"
    ),
    "plan_failed": "no joint path reaches the pose: beyond the arm's reach or joint limits",
    "collision": "the arm or hand collides with the table or the scene on the way",
    "no_contact": "the fingers close without both touching the object (too wide or off-centre)",
    "dropped": "the object slips out of the fingers while lifted",
    "lift_below_threshold": "the object does not rise with the hand",
    "velocity_invalid": "the planned motion exceeds the arm's velocity limits",
    "sim_unstable": "the simulation diverged",
    "timeout": "the episode ran out of time",
    "table_penetration": "a finger or the hand goes through the table to reach the grasp",
    "one_finger": "only one finger holds the object after the hold",
    "slipped_in_hold": "the object slips in the fingers during the hold",
    "lost_in_tug": "the grasp does not survive a 0.5 g tug",
    "not_lifted": "the object is not lifted off the table",
    "first_gripper_contact": "the opened first gripper still holds the handed-over object",
}


def cause_of(row: dict[str, Any], objective: str) -> str:
    """The cause of one row's failure under ``objective`` ('' when it did not fail)."""
    ok = bool(row.get("valid" if objective == "valid" else "success"))
    if ok:
        return ""
    reason = str(row.get("failure_reason") or "")
    if not reason and objective == "valid":
        return str(row.get("invalid_reason") or "invalid")
    stage = str(row.get("failure_stage") or "")
    return f"{reason} at {stage}" if stage else reason


def dominant_cause(rows: list[dict[str, Any]], objective: str) -> tuple[str, int, int, str]:
    """(cause, its count, rows, the physical fact) over the rows' failures; ('', 0, n, '')
    without any."""
    counts = Counter(c for c in (cause_of(r, objective) for r in rows) if c)
    if not counts:
        return "", 0, len(rows), ""
    cause, count = counts.most_common(1)[0]
    return cause, count, len(rows), FACTS.get(cause.split(" at ")[0], "")


def cause_sentence(rows: list[dict[str, Any]], objective: str) -> str:
    """``plan_failed at plan:lift in 38/40: no joint path reaches the pose: ...``."""
    cause, count, total, fact = dominant_cause(rows, objective)
    if not cause:
        return ""
    return f"{cause} in {count}/{total}" + (f": {fact}" if fact else "")
