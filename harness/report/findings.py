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

from collections import Counter
from dataclasses import dataclass

import numpy as np
import pandas as pd

from harness.report.frames import column, frame_of, series_rows
from harness.report.labels import point_label
from harness.report.placement import REACH_STAGES, outcome_kinds
from harness.report.tables import rated

FARTHER_M = 0.02  # reach failures this much farther (median) than successes: a reach boundary
MIN_SHARE = 0.1  # a failure or gap below this share of the arm's episodes is not a finding
ADVICE = {
    "table_penetration": "a finger goes through the table, which the task file lets it do "
    "(neglect_collision_names: [table] or table_contact off), and with the table physical the "
    "same plan does not hold (table_replay says why): the valid rate (the default --objective) "
    "counts these as failures; make the table physical to stop them",
    "one_finger": "only one finger holds the object: check the grasp width against the jaw",
    "slipped_in_hold": "the object slips in the hold: check friction and grip force",
    "lost_in_tug": "the grasp does not survive a 0.5 g tug: check friction and grip force",
    "not_lifted": "the object was not lifted in the validity phase",
    "first_gripper_contact": "a handover: the opened first gripper still presses on the object",
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
    for key, group in frame.groupby(["robot", "arm"], sort=True):
        robot, arm = key if isinstance(key, tuple) else (key, "")
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
    reasons = column(failed, "failure_reason").astype(str).tolist()
    stages = [str(s) or "?" for s in stage.tolist()]
    top, count = _top([f"{r} at {s}" for r, s in zip(reasons, stages, strict=True)])
    evidence = f"{len(failed)} of {n} episodes fail; {count} are {top}"
    found = []
    top_stage = top.split(" at ", 1)[1]
    if top_stage in REACH_STAGES and "object_distance_m" in group:
        distance = column(group, "object_distance_m").astype(float)
        bad = distance[~success & (stage.reindex(group.index) == top_stage)]
        good = distance[success]
        change = (
            f"{top}: the grasp poses are out of reach at the same distances as the successes: "
            "check the approach filter and the object's yaw range (see the placement plot)"
        )
        if len(good) and len(bad):
            evidence += (
                f"; their objects lie at a median {np.median(bad):.2f} m from the arm base "
                f"(successes {np.median(good):.2f} m, range {good.min():.2f}–{good.max():.2f} m)"
            )
            if np.median(bad) > np.median(good) + FARTHER_M:
                change = (
                    "objects are placed beyond its reach: narrow the placement region towards "
                    "the arm (see the placement plot)"
                )
        found.append(Finding(subject, change, evidence))
    else:
        found.append(Finding(subject, f"fix the main failure, {top}", evidence))
    if "collision_a" in failed:
        pairs = (
            failed["collision_a"].fillna("").astype(str)
            + " / "
            + failed["collision_b"].fillna("").astype(str)
        )
        named = [p for p in pairs.tolist() if p != " / "]
        if named and len(named) >= MIN_SHARE * n:
            pair, hits = _top(named)
            found.append(Finding(subject, f"avoid the collision {pair}",
                                 f"{hits} of {len(failed)} failures collide there"))  # fmt: skip
    return found


def _top(values: list[str]) -> tuple[str, int]:
    """The most frequent value and its count (first seen wins a tie)."""
    counts = Counter(values)
    best = max(counts.values())
    return next(v for v in values if counts[v] == best), best


def _validity_findings(subject: str, group: pd.DataFrame) -> list[Finding]:
    if "invalid_reason" not in group:
        return []
    kinds = outcome_kinds(group)
    successes = int((kinds != "failed").sum())
    invalid = frame_of(group[(kinds == "invalid").to_numpy()])
    if not successes or invalid.empty or len(invalid) < MIN_SHARE * successes:
        return []
    reason, count = _top(column(invalid, "invalid_reason").astype(str).tolist())
    evidence = (
        f"{len(invalid)} of {successes} reference successes are not physically valid "
        f"({count} {reason})"
    )
    if reason == "table_penetration" and "table_penetration_m" in invalid:
        depth = column(invalid, "table_penetration_m").astype(float) * 1e3
        evidence += f", {depth.min():.1f}–{depth.max():.1f} mm into the table"
    return [Finding(subject, ADVICE.get(reason, f"check {reason}"), evidence)]


def _best_findings(best: pd.DataFrame) -> list[Finding]:
    """One point for the best swept settings: where to find them, and which groups have a
    best setting below a perfect rate (the ones where a change could matter)."""
    params = [c for c in best.columns if str(c).startswith("param.")]
    compared = [row for row in series_rows(best) if int(row.get("points_compared", 1) or 1) > 1]
    if not compared:
        return []
    objective = str(best.attrs.get("objective", "reference"))
    k, n = ("valid", "n_judged") if objective == "valid" else ("successes", "n")
    short = [
        f"{row['robot']} {row['arm']} {row['object']} "
        f"{point_label(row, params) if params else row.get('point', '')} "
        f"{objective} {int(row[k])}/{int(row[n])}"
        for row in compared
        if int(row[k]) < int(row[n])
    ]
    evidence = (
        f"{len(compared)} robot/arm/object groups compared over their swept settings; best "
        "below a perfect rate: " + ("; ".join(short) if short else "none")
    )
    change = (
        f"candidate settings (highest Wilson lower bound of the {objective} rate) are in the "
        "answer table and 'Best settings per robot, arm and object'; they are not tested "
        "against the others here, harness tune confirms on fresh seeds"
    )
    return [Finding("settings", change, evidence)]
