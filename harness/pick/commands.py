"""The reference's command list for one pick block, and its progress rules.

Commands (docs/reference-pick-skill.md section 6), each a target pose plus a gripper action, in
order:

1. current EE, ``update_pose_cost_metric``    2. current EE, ``update_specific``
3. pre-grasp, ``open_gripper``                 4. pre-grasp, ``update_pose_cost_metric`` (if set)
5. grasp, ``open_gripper``                     6. grasp, final gripper command x
                                                  ``gripper_change_steps``
7. grasp, ``update_specific``                  8. grasp, ``attach_obj`` -- an EVENT only: the
                                                  object is held by friction, never welded
9. lift (grasp + U(post_min, post_max) along arm-base z), final gripper command (skipped if 0)
10. pre-grasp, final gripper command (``return_to_pregrasp``)

Progress (section 7): once per control step the head command pops when the EE is within
``t_eps`` (m) and ``o_eps`` (rad, ``2 acos(min(|q . q*|, 1))``) of its target, or when the idle
counter (the reference controller's ``num_last_cmd``) exceeds 10. As in the reference, the
counter counts control steps without an active arm trajectory, except while the head command is
an ``update_*`` one (the reference holds the arm there without counting), and it is reset only
when a command with a new target pose (more than 5e-3 away, the controller's re-plan test)
becomes head -- not on a pop, so once it exceeds 10 every further command with the same target
pops one per step (the closing commands of a grasp the arm never reached within ``t_eps``).
A command whose target differs from the previous one starts the next
planned trajectory segment (transport, approach, lift, retreat) as soon as the previous segment
has finished -- the harness plays each planned segment to its end rather than re-planning from a
moving state, so the arm never jumps. The gripper action of the head command is applied while it
is head; closing ramps the servo target to the closed width.

The executor (``harness.pick.executor``) runs the list; this module is the list and the pose
tests, free of MuJoCo, so they can be checked on their own.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from harness.config import PickConfig
from harness.transforms import quat_angle, rotation_quat

IDLE_POP_STEPS = 10  # the reference pops a command after more than 10 idle steps
REPLAN_EPS = 5e-3  # the controller re-plans (and resets its idle count) for targets this far
HOLD_FUNCTIONS = ("update_pose_cost_metric", "update_specific")  # hold the arm, count nothing


@dataclass(frozen=True)
class PickCommand:
    """One reference command: a target (by name), the function, the gripper action."""

    number: int  # the row of docs/reference-pick-skill.md section 6
    function: str
    target: Literal["current", "pregrasp", "grasp", "lift"]
    gripper: Literal["open", "close"] | None = None
    event: str | None = None


def build_commands(pick: PickConfig, lift_offset: float) -> list[PickCommand]:
    """The reference command list for a pick block (``lift_offset`` already sampled)."""
    final = "open" if pick.final_gripper_state == 1 else "close"
    final_name = "open_gripper" if final == "open" else "close_gripper"
    commands = [
        PickCommand(1, "update_pose_cost_metric", "current"),
        PickCommand(2, "update_specific", "current", event="object_out_of_planning_world"),
        PickCommand(3, "open_gripper", "pregrasp", gripper="open"),
    ]
    if pick.pre_grasp_hold_vec_weight is not None:
        commands.append(PickCommand(4, "update_pose_cost_metric", "pregrasp"))
    commands.append(PickCommand(5, "open_gripper", "grasp", gripper="open"))
    commands += [
        PickCommand(6, final_name, "grasp", gripper=final) for _ in range(pick.gripper_change_steps)
    ]
    commands.append(PickCommand(7, "update_specific", "grasp", event="object_in_planning_world"))
    commands.append(PickCommand(8, "attach_obj", "grasp", gripper=final, event="attach"))
    if lift_offset != 0.0:
        commands.append(PickCommand(9, final_name, "lift", gripper=final))
    if pick.return_to_pregrasp:
        commands.append(PickCommand(10, final_name, "pregrasp", gripper=final))
    return commands


SEGMENT_OF_TARGET = {"pregrasp": "transport", "grasp": "approach", "lift": "lift"}


def pose_reached(T_ee: np.ndarray, T_target: np.ndarray, t_eps: float, o_eps: float) -> bool:
    """The reference ``is_subtask_done`` test: ``|p - p*| < t_eps`` and
    ``2 acos(min(|q . q*|, 1)) < o_eps``, both strict."""
    if float(np.linalg.norm(T_ee[:3, 3] - T_target[:3, 3])) >= t_eps:
        return False
    return quat_angle(rotation_quat(T_ee), rotation_quat(T_target)) < o_eps


def target_moved(T_from: np.ndarray, T_to: np.ndarray) -> bool:
    """The controller's re-plan test: translation or quaternion difference norm > 5e-3."""
    if float(np.linalg.norm(T_to[:3, 3] - T_from[:3, 3])) > REPLAN_EPS:
        return True
    q_from, q_to = np.array(rotation_quat(T_from)), np.array(rotation_quat(T_to))
    if float(np.dot(q_from, q_to)) < 0.0:  # same rotation, opposite sign: compare like for like
        q_to = -q_to
    return float(np.linalg.norm(q_to - q_from)) > REPLAN_EPS
