"""The report's summary: what to change, each point with its evidence from this run's rows.

Per robot arm (objects and settings pooled):

- the main failure: its reason and stage (``failure_stage``) and, for planning failures at the
  IK stages, the object distance of the failed episodes against the successful ones (reach);
  the most frequent colliding pair when collisions fail it;
- the validity gap: reference successes that are not physically valid, by reason, with what
  the reason usually means for the task file;

and per robot, arm and object the swept setting with the highest Wilson lower bound
(``best.csv``), said to be untested against the others (``harness tune`` tests on fresh seeds).
Nothing here is a test of one setting against another; those claims live in ``harness tune``
and ``harness compare``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from harness.report.frames import column, frame_of, series_rows
from harness.report.labels import point_label
from harness.report.placement import REACH_STAGES, outcome_kinds
from harness.report.tables import rated

MIN_SHARE = 0.1  # a failure or gap below this share of the arm's episodes is not a finding
ADVICE = {
    "table_penetration": "a finger goes through the table, which the task file lets it do "
    "(neglect_collision_names: [table] or table_contact off): rank settings by the valid rate "
    "(--objective valid) or make the table physical",
    "one_finger": "only one finger holds the object: check the grasp width against the jaw",
    "slipped_in_hold": "the object slips in the hold: check friction and grip force",
    "lost_in_tug": "the grasp does not survive a 0.5 g tug: check friction and grip force",
    "not_lifted": "the object was not lifted in the validity phase",
}


@dataclass(frozen=True)
class Finding:
    """One point of the summary: what to change, and the numbers behind it."""

    subject: str
    change: str
    evidence: str


def findings(frame: pd.DataFrame, best: pd.DataFrame) -> list[Finding]:
    """The summary points of a run (see the module docstring), most failures first."""
    frame = frame_of(rated(frame))
    if frame.empty:
        return []
    out: list[Finding] = []
    for (robot, arm), group in frame.groupby(["robot", "arm"], sort=True):
        subject = f"{robot} {arm} arm"
        group = frame_of(group)
        out += _failure_findings(subject, group)
        out += _validity_findings(subject, group)
    out += _best_findings(best)
    return out


def _failure_findings(subject: str, group: pd.DataFrame) -> list[Finding]:
    success = column(group, "success").astype(bool)
    failed = frame_of(group[~success])
    n = len(group)
    if failed.empty or len(failed) < MIN_SHARE * n:
        return []
    stage = (
        column(failed, "failure_stage").fillna("").astype(str)
        if "failure_stage" in failed
        else pd.Series("", index=failed.index)
    )
    keys = failed["failure_reason"].astype(str) + " at " + stage.where(stage != "", "?")
    top, count = keys.value_counts().index[0], int(keys.value_counts().iloc[0])
    evidence = f"{len(failed)} of {n} episodes fail; {count} are {top}"
    found = []
    top_stage = top.split(" at ", 1)[1]
    if top_stage in REACH_STAGES and "object_distance_m" in group:
        distance = column(group, "object_distance_m").astype(float)
        bad = distance[~success & (stage.reindex(group.index) == top_stage)]
        good = distance[success]
        if len(good) and len(bad):
            evidence += (
                f"; their objects lie at a median {np.median(bad):.2f} m from the arm base "
                f"(successes {np.median(good):.2f} m, range {good.min():.2f}–{good.max():.2f} m)"
            )
        found.append(Finding(subject, "objects are placed beyond its reach: narrow the "
                             "placement region towards the arm (see the placement plot)",
                             evidence))  # fmt: skip
    else:
        found.append(Finding(subject, f"fix the main failure, {top}", evidence))
    if "collision_a" in failed:
        pairs = (
            failed["collision_a"].fillna("").astype(str)
            + " / "
            + failed["collision_b"].fillna("").astype(str)
        )
        pairs = pairs[pairs != " / "]
        if len(pairs) >= MIN_SHARE * n:
            pair, hits = pairs.value_counts().index[0], int(pairs.value_counts().iloc[0])
            found.append(Finding(subject, f"avoid the collision {pair}",
                                 f"{hits} of {len(failed)} failures collide there"))  # fmt: skip
    return found


def _validity_findings(subject: str, group: pd.DataFrame) -> list[Finding]:
    if "invalid_reason" not in group:
        return []
    kinds = outcome_kinds(group)
    successes = int((kinds != "failed").sum())
    invalid = group[kinds == "invalid"]
    if not successes or len(invalid) < MIN_SHARE * successes:
        return []
    reason = str(invalid["invalid_reason"].value_counts().index[0])
    count = int(invalid["invalid_reason"].value_counts().iloc[0])
    evidence = (
        f"{len(invalid)} of {successes} reference successes are not physically valid "
        f"({count} {reason})"
    )
    if reason == "table_penetration" and "table_penetration_m" in invalid:
        depth = column(invalid, "table_penetration_m").astype(float) * 1e3
        evidence += f", {depth.min():.1f}–{depth.max():.1f} mm into the table"
    return [Finding(subject, ADVICE.get(reason, f"check {reason}"), evidence)]


def _best_findings(best: pd.DataFrame) -> list[Finding]:
    params = [c for c in best.columns if str(c).startswith("param.")]
    out = []
    for row in series_rows(best):
        compared = int(row.get("points_compared", 1) or 1)
        if compared < 2:
            continue
        subject = f"{row['robot']} {row['arm']} arm, {row['object']}"
        evidence = (
            f"{int(row['successes'])}/{int(row['n'])} (95% CI {row['wilson_lo']:.2f}–"
            f"{row['wilson_hi']:.2f}), the highest lower bound of {compared} settings; not "
            "tested against the others here (harness tune tests it on fresh seeds)"
        )
        setting = point_label(row, params) if params else str(row.get("point", ""))
        out.append(Finding(subject, f"candidate setting: {setting}", evidence))
    return out
