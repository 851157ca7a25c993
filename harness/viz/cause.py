"""The moment and place that explain an episode, for its recording and its video (``Cause``).

One frame should tell a person why the episode ended as it did:

- a planning failure: the configuration that failed (``EpisodeTrace.failure_qpos``: the best
  IK attempt at an unreachable target, or the colliding configuration) with the colliding
  pair's contact point marked, or the unreached IK target;
- a finger through the table (``table_penetration``): the executed frame where the robot is
  deepest below the table top, the deepest point marked;
- a drop or a slip (``dropped``, ``lift_below_threshold``, ``not_lifted``, ``slipped_in_hold``,
  ``lost_in_tug``): the frame where the object starts to move in the hand (more than
  ``SLIP_M`` from where the fingers closed on it), the object marked;
- a strict collision during execution: the last executed frame (the run stops there), the
  pair's contact point marked;
- anything else: the last frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from harness.viz.headline import outcome_kind

SLIP_M = 0.01  # object moved this far in the TCP frame since the grasp closed: it slips
SLIPS = ("dropped", "lift_below_threshold", "not_lifted", "slipped_in_hold", "lost_in_tug")


@dataclass(frozen=True)
class Cause:
    """What to show: a configuration (full qpos), the trace row it came from (None for a
    configuration that was never executed), a world point to mark and what the mark says."""

    qpos: np.ndarray | None
    row: int | None
    point: np.ndarray | None
    label: str


def _reason(row: Any) -> str:
    kind = outcome_kind(row)
    if kind == "invalid":
        return str(row.get("invalid_reason") or "")
    if kind == "failed":
        return str(row.get("failure_reason") or "")
    return ""


def find_cause(row: Any, trace: Any, model: Any, scene: Any | None = None) -> Cause:
    """The frame and mark that explain ``row`` (see the module docstring)."""
    reason = _reason(row)
    executed = len(trace.time) > 0
    if trace.failure_qpos is not None:
        return _planning_cause(row, trace, model)
    if not executed:
        qpos = trace.qpos_start
        return Cause(qpos, None, _target_point(trace), f"stopped before moving: {reason}")
    last = len(trace.time) - 1
    if reason == "table_penetration" and scene is not None:
        return _penetration_cause(trace, model, scene)
    if reason in SLIPS:
        return _slip_cause(trace, reason)
    if reason == "collision":
        point = _pair_point(model, trace.qpos[last], row, trace)
        return Cause(trace.qpos[last], last, point, _pair_label(row) or "collision")
    if reason:
        return Cause(trace.qpos[last], last, None, reason)
    return Cause(trace.qpos[last], last, trace.object_pose[last, :3], _held(row))


def _held(row: Any) -> str:
    """What a valid grasp survived (the validity phase's robustness)."""
    try:
        robustness = float(row.get("robustness_g"))
    except (TypeError, ValueError):
        robustness = math.nan
    if math.isfinite(robustness) and robustness > 0:
        return f"held: 1 s hold, tugs up to {robustness:g} g in six directions"
    return "end of the episode"


def _pair_label(row: Any) -> str:
    a, b = str(row.get("collision_a") or ""), str(row.get("collision_b") or "")
    return f"{a} hits {b}" if a or b else ""


def _target_point(trace: Any) -> np.ndarray | None:
    for T in (trace.T_world_pregrasp, trace.T_world_grasp):
        if T is not None:
            return np.asarray(T)[:3, 3]
    if trace.tested_T_world_pregrasp is not None and len(trace.tested_T_world_pregrasp):
        return np.asarray(trace.tested_T_world_pregrasp[-1])[:3, 3]
    return None


def _planning_cause(row: Any, trace: Any, model: Any) -> Cause:
    stage = str(row.get("failure_stage") or "")
    pair = _pair_label(row)
    if pair:
        return Cause(
            trace.failure_qpos, None, _pair_point(model, trace.failure_qpos, row, trace), pair
        )
    target = "grasp" if stage.endswith("ik_grasp") else "pre-grasp"
    message = str(row.get("error_message") or "")
    residual = (
        message.split("IK residual ", 1)[1].split(" /", 1)[0] if "IK residual" in message else ""
    )
    label = f"{target} out of reach" + (f" (best IK attempt {residual} off)" if residual else "")
    if "ik" not in stage:
        label = f"{stage}: {message}"[:90]
    point = (
        trace.tested_T_world_grasp[-1][:3, 3]
        if target == "grasp"
        and trace.tested_T_world_grasp is not None
        and len(trace.tested_T_world_grasp)
        else _target_point(trace)
    )
    return Cause(trace.failure_qpos, None, point, label)


def _pair_point(model: Any, qpos: np.ndarray, row: Any, trace: Any) -> np.ndarray | None:
    """Where the two named bodies meet at ``qpos``: the midpoint of the closest points between
    their geoms (``mj_geomDistance``, which also measures pairs the physics excludes, such as
    a robot's own links); None when a body is unknown."""
    import mujoco

    names = [str(row.get("collision_a") or ""), str(row.get("collision_b") or "")]
    if not all(_has_body(model, name) for name in names):
        return None
    data = mujoco.MjData(model)
    if model.nmocap:
        data.mocap_pos[:], data.mocap_quat[:] = trace.mocap_pos, trace.mocap_quat
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    ids = [model.body(name).id for name in names]
    geoms = [np.flatnonzero(model.geom_bodyid == i) for i in ids]
    best: tuple[float, np.ndarray] | None = None
    fromto = np.zeros(6)
    for a in geoms[0]:
        for b in geoms[1]:
            distance = mujoco.mj_geomDistance(model, data, int(a), int(b), 0.5, fromto)
            if best is None or distance < best[0]:
                best = (float(distance), (fromto[:3] + fromto[3:]) / 2.0)
    if best is not None:
        return best[1]
    return np.mean([data.xpos[i] for i in ids], axis=0)


def _has_body(model: Any, name: str) -> bool:
    try:
        model.body(name)
    except KeyError:
        return False
    return True


def _penetration_cause(trace: Any, model: Any, scene: Any) -> Cause:
    import mujoco

    from harness.pick.penetration import TablePenetration

    meter = TablePenetration(scene)
    data = mujoco.MjData(model)
    if model.nmocap:
        data.mocap_pos[:], data.mocap_quat[:] = trace.mocap_pos, trace.mocap_quat
    best = (-1.0, 0, np.zeros(3), -1)
    for k, qpos in enumerate(trace.qpos):
        data.qpos[:] = qpos
        mujoco.mj_kinematics(model, data)
        depth, geom, point = meter.deepest(data)
        if depth > best[0]:
            best = (depth, k, point, geom)
    depth, k, point, geom = best
    body = model.body(int(model.geom_bodyid[geom])).name if geom >= 0 else "robot"
    return Cause(
        trace.qpos[k],
        k,
        point,
        f"{body} {depth * 1e3:.1f} mm through the table at t={trace.time[k]:.2f} s",
    )


def _slip_cause(trace: Any, reason: str) -> Cause:
    """The first frame after the grasp closed where the object moved ``SLIP_M`` in the hand."""
    from harness.transforms import invert_T, pose_to_T

    phases = np.asarray(trace.phase, dtype=str)
    closed = np.flatnonzero(np.char.startswith(phases, "close_gripper"))
    last = len(trace.time) - 1
    if not len(closed):
        return Cause(trace.qpos[last], last, trace.object_pose[last, :3], reason)
    start = int(closed[0])
    end_close = start
    while end_close + 1 <= last and phases[end_close + 1].startswith("close_gripper:grasp"):
        end_close += 1

    def in_hand(k: int) -> np.ndarray:
        T_tcp = pose_to_T(trace.tcp_pose[k, :3], trace.tcp_pose[k, 3:])
        return (invert_T(T_tcp) @ np.append(trace.object_pose[k, :3], 1.0))[:3]

    reference = in_hand(end_close)
    for k in range(end_close + 1, last + 1):
        moved = float(np.linalg.norm(in_hand(k) - reference))
        if moved > SLIP_M:
            at = f"t={trace.time[k]:.2f} s"
            label = f"object slips {moved * 1e3:.0f} mm in the hand at {at}, {phases[k]} ({reason})"
            return Cause(trace.qpos[k], k, trace.object_pose[k, :3], label)
    height = trace.object_pose[last, 2] - trace.object_pose[0, 2]
    label = f"{reason}: object rose {height * 1e3:.0f} mm" if math.isfinite(height) else reason
    return Cause(trace.qpos[last], last, trace.object_pose[last, :3], label)
