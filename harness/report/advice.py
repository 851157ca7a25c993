"""Advice for a group of failures: the physical cause in the rows' own numbers, and one action.

"fix the main failure, plan_failed at plan:lift" names a symptom; the rows say more. A reach or
planning failure records the joint its best IK attempt stopped at (``limit_joint``,
``name:upper``) and its residual; with the robot's URDF that is "left_joint5 at its upper limit
+70.0 deg". A failure at the IK stages records the object's distance from the arm base
(``object_distance_m``; ``reach_limit`` where the rows have it); a drop or a slip records the
slip (``slip_m``, ``hold_slip_m``); a collision the pair; a miss the TCP's grasp error. Each
cause comes with the one change that addresses it, naming the key to change.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass
from functools import cache

import numpy as np
import pandas as pd

from harness.report.frames import column, frame_of

LIMIT_SHARE = 0.5  # a joint at its limit in at least this share of the group names the cause


@dataclass(frozen=True)
class Advice:
    """``cause``: what physically happens, with numbers; ``action``: the one change to make."""

    cause: str
    action: str

    def text(self) -> str:
        return f"{self.cause}: {self.action}"


@cache
def _limits_deg(robot: str, joint: str) -> tuple[float, float] | None:
    """The joint's URDF position limits in degrees (None when the robot cannot be loaded)."""
    try:
        from harness.robots import RobotModel

        lower, upper = RobotModel.load(robot).joint_limits(joint)
    except Exception:  # an unknown or moved robot: the joint is named without its limit
        return None
    return math.degrees(lower), math.degrees(upper)


def limit_cause(robot: str, failed: pd.DataFrame) -> str | None:
    """``split_aloha left_joint5 at its upper limit (+70 deg) in 9 of 12``, when one joint
    at one limit stops most of ``failed``'s best IK attempts."""
    if "limit_joint" not in failed:
        return None
    names = [str(v) for v in column(failed, "limit_joint").fillna("").tolist() if str(v)]
    if not names:
        return None
    top, count = Counter(names).most_common(1)[0]
    if count < LIMIT_SHARE * len(failed):
        return None
    joint, _, side = top.partition(":")
    limits = _limits_deg(robot, joint)
    value = ""
    if limits is not None and side in ("lower", "upper"):
        value = f" ({limits[side == 'upper']:+.0f} deg)"
    where = f"its {side} limit" if side else "a limit"
    return f"{robot} {joint} at {where}{value} in {count} of {len(failed)}"


def _median(frame: pd.DataFrame, name: str, scale: float = 1.0) -> float:
    if name not in frame:
        return math.nan
    values = pd.Series(pd.to_numeric(column(frame, name), errors="coerce")).dropna()
    return float(np.median(values.to_numpy(dtype=float))) * scale if len(values) else math.nan


FARTHER_M = 0.02  # failures this much farther (median) than the successes: placement is the cause


def reach_advice(limit: str | None, failed: pd.DataFrame, group: pd.DataFrame) -> Advice:
    """A target out of reach (the stage is said beside it): the joint at its limit and how far
    the objects lie; the action moves the objects nearer when the failures lie farther than the
    successes, else turns the grasp directions towards what the arm reaches."""
    distance = _median(failed, "object_distance_m")
    good = _median(frame_of(group[column(group, "success").astype(bool)]), "object_distance_m")
    residual = _median(failed, "ik_residual_mm")
    bits = [limit] if limit else []
    if not math.isnan(residual):
        bits.append(f"best IK attempt a median {residual:.0f} mm short")
    if not math.isnan(distance):
        where = f"objects a median {distance:.2f} m from the arm base"
        bits.append(where + (f" (successes {good:.2f} m)" if not math.isnan(good) else ""))
    cause = "out of reach" + (f": {'; '.join(bits)}" if bits else "")
    if not math.isnan(distance) and not math.isnan(good) and distance > good + FARTHER_M:
        action = "place the objects nearer the arm base (the task's placement region; "
    else:
        action = "narrow approach_filter towards the directions the arm reaches ("
    return Advice(cause, action + "see the placement plot)")


def failure_advice(
    robot: str, reason: str, stage: str, failed: pd.DataFrame, group: pd.DataFrame
) -> Advice:
    """The cause and the action for ``failed`` (the group's episodes failing with ``reason`` at
    ``stage``), ``group`` being every episode of the robot arm."""
    limit = limit_cause(robot, failed)
    reach = reason in ("plan_failed", "no_feasible_candidate") and (
        "ik" in stage or stage.endswith("lift") or limit is not None
    )
    if reach:
        return reach_advice(limit, failed, group)
    if reason == "collision":
        pairs = _top_pair(failed)
        return Advice(
            f"a collision at {stage}" + (f" between {pairs}" if pairs else ""),
            "raise pre_grasp_offset so the approach starts clear of the object",
        )
    if reason in ("dropped", "lift_below_threshold"):
        slip = _median(failed, "slip_m", 1e3)
        force = _median(failed, "min_finger_force_n")
        bits = [f"the object slips {slip:.0f} mm in the grip"] if not math.isnan(slip) else []
        if not math.isnan(force):
            bits.append(f"weakest finger {force:.1f} N")
        return Advice(
            ", ".join(bits) or "the object leaves the grip in the lift",
            "raise the grip force (gripper.force) or the object's friction if it is too low",
        )
    if reason == "no_contact":
        error = _median(failed, "tcp_grasp_error_m", 1e3)
        return Advice(
            "the fingers close on nothing"
            + (
                f": the TCP ends {error:.0f} mm from its grasp pose"
                if not math.isnan(error)
                else ""
            ),
            "check the grasp file against the mesh (grasp_scale, npy_name)",
        )
    if reason == "filter_empty":
        return Advice(
            "no grasp of the file points the way the filter asks",
            "widen approach_filter's angle (see harness grasps inspect FILE --robot R)",
        )
    if reason == "no_feasible_candidate":
        return Advice(
            f"every candidate fails at {stage}",
            "widen approach_filter so candidates from other directions are tried",
        )
    if reason in ("velocity_invalid", "sim_unstable"):
        return Advice(
            f"the simulation ran away at {stage}",
            "lower speed_scale or physics.timestep",
        )
    return Advice(f"{reason} at {stage}", "open an example episode's recording (harness view)")


def _top_pair(failed: pd.DataFrame) -> str:
    if "collision_a" not in failed:
        return ""
    pairs = (
        column(failed, "collision_a").fillna("").astype(str)
        + " and "
        + column(failed, "collision_b").fillna("").astype(str)
    )
    named = [p for p in pairs.tolist() if p != " and "]
    return Counter(named).most_common(1)[0][0] if named else ""


def validity_advice(reason: str, invalid: pd.DataFrame) -> Advice | None:
    """The cause (with the rows' numbers) and one action for reference successes that are
    not valid for ``reason``; None where ``findings.ADVICE``'s sentence says it already."""
    if reason == "slipped_in_hold":
        slip = _median(invalid, "hold_slip_m", 1e3)
        turn = _median(invalid, "hold_rotation_rad")
        bits = [
            f"{slip:.1f} mm" if not math.isnan(slip) else "",
            f"{turn:.2f} rad" if not math.isnan(turn) else "",
        ]
        moved = " and ".join(b for b in bits if b)
        return Advice(
            "the object slips in the hand during the hold"
            + (f" (median {moved})" if moved else ""),
            "raise the grip force (gripper.force) or check the object's friction",
        )
    if reason == "lost_in_tug":
        force = _median(invalid, "min_finger_force_n")
        held = f" (weakest finger a median {force:.1f} N)" if not math.isnan(force) else ""
        return Advice(
            f"the grasp lets go under the tug ladder{held}",
            "raise the grip force (gripper.force)",
        )
    if reason == "one_finger":
        force = _median(invalid, "min_finger_force_n")
        held = f" (the other a median {force:.1f} N)" if not math.isnan(force) else ""
        return Advice(
            f"only one finger presses on the object{held}",
            "choose grasps whose width fits the jaw (the grasp file's widths, grasp_scale)",
        )
    return None
