"""Row records that locate an episode: where its object stood and where it failed.

``placement_columns``: the target object's pose at reset (after settling, when the grasp is
chosen) in the arm base frame (x forward, y left, z up; ARCHITECTURE.md) and its horizontal
distance from the arm base, so where reach ends can be mapped from the rows alone.

The ``*_failure`` functions give ``failure_stage`` and the colliding pair (``collision_a``,
``collision_b``, body names, '' when the failure was no collision) for the stage the episode
stopped at, so failures group without parsing ``error_message``; for a target out of reach
also the best IK attempt's position residual and the joint at a limit there (``limit_joint``,
``ik_residual_mm``) and what limits the reach (``reach_limit``: joint_limit, lift_height,
collision, beyond_reach, unconverged; ``harness.planning.reach``). Stages:

- ``settle`` / ``warmup``: the physics went unstable before the motion;
- ``filter``: no candidate passed the direction filters;
- ``feasibility:<test stage>``: strict semantics, no candidate passed; the last one tested
  failed at that stage (``ik_pregrasp``, ``ik_grasp``, ``transport``, ``approach``, ``lift``,
  ``return``);
- ``plan:<stage>``: the chosen candidate's motion could not be planned (the same stages, or
  ``timing``);
- ``execute:<function>:<target>``: the command running when the execution failed (e.g.
  ``execute:move:lift`` for a drop in the lift; ``execute:verdict`` at the final checks).
"""

from __future__ import annotations

import math

import numpy as np

from harness.episode.records import FailureLocationColumns, PlacementColumns
from harness.planning.plans import CandidateVerdict, FailurePoint
from harness.transforms import invert_T


def placement_columns(T_world_base: np.ndarray, T_world_object: np.ndarray) -> PlacementColumns:
    """The object's position and yaw in the arm base frame, and its distance from the base axis
    in the base's horizontal plane (m, degrees)."""
    T_base_object = invert_T(np.asarray(T_world_base)) @ np.asarray(T_world_object)
    x, y, z = (float(v) for v in T_base_object[:3, 3])
    rotation = T_base_object[:3, :3]
    yaw = math.degrees(math.atan2(float(rotation[1, 0]), float(rotation[0, 0])))
    return PlacementColumns(x, y, z, yaw, math.hypot(x, y))


def _columns(
    stage: str, pair: tuple[str, str] | None, point: FailurePoint | None = None
) -> FailureLocationColumns:
    a, b = pair if pair is not None else ("", "")
    reach = point.reach_limit if point is not None else ""
    if point is None or point.residual_m is None:
        return FailureLocationColumns(stage, a, b, reach_limit=reach)
    return FailureLocationColumns(stage, a, b, point.limit_joint, point.residual_m * 1e3, reach)


def stage_failure(stage: str) -> FailureLocationColumns:
    """A failure at a stage without a configuration (settle, warmup, filter, timing)."""
    return _columns(stage, None)


def plan_failure(stage: str, point: FailurePoint | None) -> FailureLocationColumns:
    """The chosen candidate's motion failed to plan at ``stage`` (with its failing point)."""
    return _columns(f"plan:{stage}", point.pair if point is not None else None, point)


def feasibility_failure(verdicts: list[CandidateVerdict]) -> FailureLocationColumns:
    """No candidate was feasible: the stage and pair of the last one tested."""
    if not verdicts:
        return _columns("feasibility", None)
    last = verdicts[-1]
    point = last.failure_point
    return _columns(f"feasibility:{last.stage}", point.pair if point is not None else None, point)


def execution_failure(phase: str, pair: tuple[str, str] | None) -> FailureLocationColumns:
    """The execution failed while ``phase`` (``function:target``) was running."""
    return _columns(f"execute:{phase}" if phase else "execute", pair)
