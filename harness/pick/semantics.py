"""The pick's semantics as one policy: every place where ``reference`` and ``strict`` differ.

``semantics: reference`` reproduces the InternDataEngine Pick skill, quirks included;
``semantics: strict`` is a stricter harness of the same skill (docs/semantics.md has the audit,
row by row). ``Semantics.from_pick(pick)`` resolves the choice ONCE per episode into plain
fields, and the episode, the feasibility test and the executor read those fields instead of
comparing the name: a difference between the two is a field here, and a test can state it
without running an episode.

The candidate order (``harness.grasps``) and the strict filter validation
(``harness.config``) still read ``pick.semantics`` themselves.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from harness.config import PickConfig
from harness.grasps import CandidateRule
from harness.pick.outcome import PickOutcome
from harness.pick.verdict import VerdictTerm, reference_terms, strict_terms
from harness.planning.planner import LiftPath
from harness.planning.world import PlanningWorld
from harness.sim.composition import TABLE_NAME

# Under reference a forward test plans only the pre-grasp and the grasp (pick.py
# simple_generate_manip_cmds: test_single_forward / test_single_ik on those two poses); the carry
# (lift, return) is planned for the chosen candidate alone, and a failure there is plan_failed.
# Strict tests the whole chain it executes, lift included.
# Strict semantics plan the robot this far (m) from the table, so that servo tracking lag (the
# small arms' wrists have kp 10) does not dip a finger into it during execution.
STRICT_TABLE_CLEARANCE = 0.005
# The reference workflow's planning-world ignore list (docs/reference-pick-skill.md section 8;
# template_controller.py _get_default_ignore_substring, simbox_dual_workflow.py
# _initialize_controllers): names containing any of these are never obstacles for its planner
# (the table among them). A robot's own ``ignore_substring`` replaces this list.
REFERENCE_IGNORE_SUBSTRINGS = ("material", "Plane", "conveyor", "scene", "table")


@dataclass(frozen=True)
class Semantics:
    """The reference-vs-strict decisions of one pick (see the module docstring).

    Planning world: ``table_in_planning`` (strict; the reference planner never sees the table),
    ``table_clearance`` (m), ``ignore_substring`` (objects left out of planning).
    Feasibility: ``test_carry`` (a forward test plans the lift and the return too),
    ``fixed_orientation_in_test`` (candidates are tested at ``fixed_orientation``, so the tested
    plan is the executed one), ``pregrasp_along_fixed_axis`` (the pre-grasp backs off along the
    fixed orientation's approach axis), ``fall_back_to_last_tested`` (no feasible candidate:
    proceed with the last one tested instead of ``no_feasible_candidate``).
    Execution: ``check_collisions`` (robot-environment contacts fail the episode),
    ``check_closing_forces`` (both fingers must carry ``min_finger_force`` when the closing
    ends), ``hold_after_list`` (after the list: finish, come to rest, hold, then judge; else
    judge at once, as the reference).
    Candidates: ``candidates`` (the order rule and whether impossible filters are errors).
    Verdict: ``validity_is_verdict`` (the validity phase always runs and is the success).
    Lift: ``lift_path`` (``joint``: a joint-space plan to the lift pose, the reference's;
    ``cartesian``: the straight line up), ``pick.lift_path`` when set.
    """

    name: Literal["reference", "strict"]
    table_in_planning: bool
    table_clearance: float
    ignore_substring: tuple[str, ...]
    test_carry: bool
    fixed_orientation_in_test: bool
    pregrasp_along_fixed_axis: bool
    fall_back_to_last_tested: bool
    check_collisions: bool
    check_closing_forces: bool
    hold_after_list: bool
    candidates: CandidateRule
    validity_is_verdict: bool = False
    lift_path: LiftPath = "cartesian"

    @classmethod
    def from_pick(cls, pick: PickConfig) -> Semantics:
        """The policy of ``pick.semantics`` (with the pick's own ignore list under reference)."""
        strict = pick.semantics == "strict"
        ignored = reference_ignore_list(pick)
        return cls(
            name=pick.semantics,
            # reference: the table is out when the ignore list names it (the default does; a
            # robot list that does not, e.g. ["material"], keeps it in)
            table_in_planning=strict or not any(part in TABLE_NAME for part in ignored),
            table_clearance=STRICT_TABLE_CLEARANCE if strict else 0.0,
            ignore_substring=() if strict else ignored,
            test_carry=strict,
            fixed_orientation_in_test=strict,
            pregrasp_along_fixed_axis=strict,
            fall_back_to_last_tested=not strict,
            check_collisions=strict,
            check_closing_forces=strict,
            hold_after_list=strict,
            validity_is_verdict=strict,
            candidates=CandidateRule(order=pick.semantics, reject_impossible_filters=strict),
            # reference: cuRobo plans the lift in joint space (template_controller.py plan);
            # strict keeps the straight line it tests (unless the pick says otherwise)
            lift_path=pick.lift_path or ("cartesian" if strict else "joint"),
        )

    def planning_world(self, target: str) -> PlanningWorld:
        """What the planner treats as an obstacle while picking ``target``.

        ``reference``: the world the reference's planner builds. Its controllers leave every
        scene name containing one of its ignore list (``reference_ignore_list``) out, so the
        table is never an obstacle, even where robot-table contact is physical
        (``neglect_collision_names`` only sets the physics collision groups, quirk 21); the
        robot's own name is on that list (template_controller.py __init__ appends it), so no
        robot part is an obstacle and only the planned arm's self-collision model counts
        (cuRobo's arm configs); the pick removes the target for the pre-grasp / grasp tests and
        plans (pick.py simple_generate_manip_cmds: ``update_specific`` with the target's name
        appended) and, after closing, attaches it to the hand for the lift (``attach_obj``,
        spheres 1 cm up: template_controller.py attach_obj). A transport through the target
        then knocks it over in MuJoCo as it would in PhysX. ``strict``: everything physical is
        an obstacle, the table with a clearance, the target too (the fingers may touch it on the
        approach), the whole robot, every robot-robot contact.
        """
        reference = self.name == "reference"
        return PlanningWorld(
            target,
            check_table=self.table_in_planning,
            check_target=not reference,
            table_clearance=self.table_clearance,
            ignore_substring=self.ignore_substring,
            hold_lift=True,  # the reference plans the arm alone, the lift held at its home
            attach_target=reference,
            whole_robot=not reference,
            rule=self.name,
        )

    def verdict_terms(self, pick: PickConfig, out: PickOutcome) -> tuple[VerdictTerm, ...]:
        """The final checks: the reference's when the list empties, strict's (the validity
        verdict) after the validity phase."""
        if self.hold_after_list:
            return strict_terms(pick, out)
        return reference_terms(pick, out)


def reference_ignore_list(pick: PickConfig) -> tuple[str, ...]:
    """The reference planner's ignore list for this pick: the robot's ``ignore_substring`` when
    it has one, REPLACING the controllers' default (template_controller.py __init__), else
    ``REFERENCE_IGNORE_SUBSTRINGS``; then the pick's own ``ignore_substring`` (pick.py adds it
    to the controller's list). Each substring once."""
    base = (
        REFERENCE_IGNORE_SUBSTRINGS
        if pick.robot_ignore_substring is None
        else tuple(pick.robot_ignore_substring)
    )
    return tuple(dict.fromkeys((*base, *pick.ignore_substring)))
