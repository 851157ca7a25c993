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
    """

    target: str
    check_table: bool = True
    check_target: bool = True
    table_clearance: float = 0.0
    ignore_substring: tuple[str, ...] = ()
    hold_lift: bool = False
