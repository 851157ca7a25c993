"""The EE poses a pick commands: pre-grasp, grasp and lift of a candidate, and the timed plan.

``command_targets`` is the reference's pose arithmetic (docs/reference-pick-skill.md section 6) in
the arm
base frame; ``CandidatePoses`` applies it to the candidates of one episode and moves the result
into the world; ``PickTargets`` is what the executor is given: the planned world poses and the
timed segments that reach them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from harness.planning.timing import Trajectory


@dataclass
class PickTargets:
    """World poses of the EE targets, and the timed segments that reach them."""

    T_world_pregrasp: np.ndarray
    T_world_grasp: np.ndarray
    T_world_lift: np.ndarray | None
    segments: dict[str, Trajectory]  # transport, approach, lift, retreat


def command_targets(
    T_base_grasp: np.ndarray,
    pre_grasp_offset: float,
    approach_index: int,
    lift_offset: float,
    fixed_rotation: np.ndarray | None = None,
    pregrasp_along_fixed_axis: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Arm-base-frame pre-grasp, grasp and lift poses of one candidate (section 6).

    The pre-grasp is the grasp moved ``pre_grasp_offset`` back along EE column
    ``approach_index`` (the reference picks column 0 when "r5a" is in the planner file name and
    column 2 otherwise, quirk 14: the same column as ``ee_axis`` on all three robots); the lift
    is the grasp moved ``lift_offset`` up along base z, in the grasp's orientation (quirk 12).
    ``fixed_rotation`` replaces the orientation of all three. Under ``reference`` semantics the
    positions stay those of the candidate (the reference overwrites only the quaternions, after
    computing the pre-grasp from the candidate's own approach axis, quirk 13); under
    ``strict`` (``pregrasp_along_fixed_axis``, ``Semantics.pregrasp_along_fixed_axis``) the
    pre-grasp backs off along the fixed orientation's approach axis, so the approach is straight
    along the executed hand axis.
    """
    T_grasp = np.array(T_base_grasp, dtype=float)
    if fixed_rotation is not None and pregrasp_along_fixed_axis:
        T_grasp[:3, :3] = fixed_rotation
    T_pre = T_grasp.copy()
    T_pre[:3, 3] -= pre_grasp_offset * T_grasp[:3, approach_index]
    if fixed_rotation is not None:
        T_grasp[:3, :3] = fixed_rotation
        T_pre[:3, :3] = fixed_rotation
    T_lift = None
    if lift_offset != 0.0:
        T_lift = T_grasp.copy()
        T_lift[2, 3] += lift_offset
    return T_pre, T_grasp, T_lift


@dataclass(frozen=True)
class CandidatePoses:
    """The command poses of an episode's candidates, in the world frame.

    One arm base, approach column, lift offset and ``fixed_orientation`` (as a rotation, or
    None) for every candidate of the episode; ``world(T_base_grasp, apply_fixed)`` gives the
    world pre-grasp, grasp and lift of one, with or without the fixed orientation.
    """

    T_world_base: np.ndarray
    pre_grasp_offset: float
    approach_index: int
    lift_offset: float
    fixed_rotation: np.ndarray | None
    pregrasp_along_fixed_axis: bool

    def world(
        self, T_base_grasp: np.ndarray, apply_fixed: bool
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        T_pre, T_grasp, T_lift = command_targets(
            T_base_grasp,
            self.pre_grasp_offset,
            self.approach_index,
            self.lift_offset,
            self.fixed_rotation if apply_fixed else None,
            self.pregrasp_along_fixed_axis,
        )
        T_world_base = self.T_world_base
        return (
            T_world_base @ T_pre,
            T_world_base @ T_grasp,
            T_world_base @ T_lift if T_lift is not None else None,
        )
