"""Which picks of a file depend on the skills before them.

The reference runs a file's skills in order: stages one after another, a robot's phases one
after another, the arms of a phase side by side, each arm's skills in order
(workflows/simbox_dual_workflow.py). pick-harness starts every pick from the initial scene. A
pick whose object an earlier skill already handled (picked, placed, moved: the skill's first
object) starts, in the reference, from the state that skill left.

One such dependency is replayed: a **handover** (``handover_prelude``), where the object's
earlier skills are a pick by another arm of the same robot, optionally followed by that arm's
``goto__pose`` -- the reference's Split ALOHA handover files
(``tasks/long_horizon/split_aloha/handover/lr/*.yaml``: left pick, left goto__pose, right
pick). The second pick's episode then runs those skills first (``TaskConfig.handover``,
``harness.episode.handover``). Any other dependency would be another task run from the table,
so such a pick is marked not runnable in isolation (``TaskConfig.not_runnable``): its rows say
why and stay out of every rate.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class SkillRef:
    """One skill of the ``skills`` tree: where it runs and the object it handles."""

    stage: int
    robot: str
    phase: int
    arm: str
    index: int
    key: str
    name: str
    target: str | None  # the skill's first object, None when it names none

    def runs_before(self, other: SkillRef) -> bool:
        """This skill ends before ``other`` starts (skills running side by side do not)."""
        if self.stage != other.stage:
            return self.stage < other.stage
        if self.robot != other.robot:
            return False  # robots of one stage run side by side
        if self.phase != other.phase:
            return self.phase < other.phase
        return self.arm == other.arm and self.index < other.index


def skill_target(block: dict[str, Any]) -> str | None:
    """The object a skill handles: the first of its ``objects``."""
    objects = block.get("objects")
    if isinstance(objects, list) and objects:
        return str(objects[0])
    return None


# The reference's name of the Goto_Pose skill (base_skill.py register_skill: the class name
# split at capitals and joined by "_", lowercased: "Goto_Pose" -> "goto__pose").
GOTO_POSE = "goto__pose"


@dataclass(frozen=True)
class Prelude:
    """The skills a handover's second pick replays first: the other arm's pick, then its goto."""

    pick: SkillRef
    goto: SkillRef | None


def earlier_skills(pick: SkillRef, skills: list[SkillRef]) -> list[SkillRef]:
    """The skills that handle ``pick``'s object and end before it starts, in order."""
    if pick.target is None:
        return []
    return [s for s in skills if s.target == pick.target and s.runs_before(pick)]


def handover_prelude(pick: SkillRef, skills: list[SkillRef]) -> Prelude | None:
    """The prelude when ``pick`` is a handover's second pick: the object's earlier skills are a
    pick by another arm of the same robot, optionally followed by that arm's ``goto__pose``."""
    earlier = earlier_skills(pick, skills)
    if not earlier:
        return None
    first, rest = earlier[0], earlier[1:]
    if first.name != "pick" or first.robot != pick.robot or first.arm == pick.arm:
        return None
    if not rest:
        return Prelude(first, None)
    goto = rest[0]
    same_arm = (goto.robot, goto.arm) == (first.robot, first.arm)
    if len(rest) == 1 and goto.name == GOTO_POSE and same_arm:
        return Prelude(first, goto)
    return None


def not_runnable_reason(pick: SkillRef, skills: list[SkillRef]) -> str | None:
    """Why ``pick`` cannot run from the initial scene, or None when it can."""
    earlier = earlier_skills(pick, skills)
    if not earlier or handover_prelude(pick, skills) is not None:
        return None
    last = earlier[-1]
    return (
        f"{pick.key} picks {pick.target!r}, which {last.key} ({last.name}, {last.robot} "
        f"{last.arm} arm) handles before it: in the reference this pick starts from the state "
        "the earlier skills leave (e.g. the object held by the other gripper), which "
        "pick-harness does not replay, so it is not runnable in isolation and stays out of "
        "every rate"
    )
