"""PlanningWorld: what the planner treats as an obstacle for one pick.

A value, not a policy: the pick's semantics decide it (``harness.pick.semantics``) and the
planner applies it (``PickPlanner.sync``). Keeping the rule's output in one small type is what
lets a test state "under reference the table is absent from planning" without running a plan.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class PlanningWorld:
    """The obstacles and posture constraints of one planning query.

    ``target``: the object being picked. ``check_table``: the table is an obstacle.
    ``check_target``: the target object is an obstacle (the fingers may still touch it on the
    approach). ``table_clearance`` (m): coming closer than this to the table is a collision.
    ``ignore_substring``: other objects whose name contains one of these are left out.
    ``hold_lift``: a lift joint stays at its current value for every IK solve and path.
    ``attach_target``: once the grasp is reached, the carry (lift, return) moves the target
    with the end effector, ``ATTACH_OFFSET`` higher than it lies (the reference's
    ``attach_obj``), and checks it against the rest of the planning world.
    ``whole_robot``: every robot part is in the planning world (other arm, lift carriage,
    base) and every robot-robot contact counts; False keeps only the planned arm: its parts
    against the environment and against each other (the reference leaves the robot out of
    its world and checks the arm's own self-collision model).
    ``rule``: the name of the rule that built this world (the row's ``planning_world``).
    """

    target: str
    check_table: bool = True
    check_target: bool = True
    table_clearance: float = 0.0
    ignore_substring: tuple[str, ...] = ()
    hold_lift: bool = False
    attach_target: bool = False
    whole_robot: bool = True
    rule: str = ""


# The reference attaches the grasped object to the planner's robot model 1 cm above where it
# lies (template_controller.py attach_obj: cuRobo ``attach_objects_to_robot`` with
# ``world_objects_pose_offset`` (0, 0, 0.01) in the planning frame), so the lifted object does
# not start in contact with the surface it stood on.
ATTACH_OFFSET = 0.01
