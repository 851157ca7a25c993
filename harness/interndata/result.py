"""The result of mapping a file: one ``InternDataPick`` per pick skill, and the skipped skills."""

from __future__ import annotations

from dataclasses import dataclass, field

from harness.config.task import TaskConfig


@dataclass(frozen=True)
class SkippedSkill:
    """A skill of the file that pick-harness does not run (anything but ``pick``)."""

    key: str  # where it is: tasks[0].skills[0].split_aloha[0].right[1]
    name: str  # place, heuristic__skill, ...
    robot_name: str
    arm: str
    mode: str | None = None  # heuristic__skill's mode (home, ...), when given

    def describe(self) -> str:
        """``tasks[0].skills[0].split_aloha[0].right[1]: place (split_aloha right)``."""
        mode = f" mode {self.mode}" if self.mode else ""
        return f"{self.key}: {self.name}{mode} ({self.robot_name} {self.arm})"


@dataclass(frozen=True)
class InternDataPick:
    """One ``pick`` skill of an InternDataEngine file as a harness task, with its provenance.

    ``stage`` indexes the file's ``skills`` list (stages run one after another), ``phase`` the
    robot's list of arm groups inside the stage (also sequential), ``skill_index`` the arm's
    skill list. ``order`` is the pick's position in execution order over the whole file.
    ``skipped`` holds the notes of everything in the file the task does not carry (other skills,
    ignored keys, approximations); ``skipped_skills`` the file's skills that are not run (the
    same for every pick of a file).
    """

    task: TaskConfig
    task_index: int
    stage: int
    phase: int
    robot_name: str
    arm: str
    skill_index: int
    order: int
    key: str
    skipped: list[str] = field(default_factory=list)
    skipped_skills: tuple[SkippedSkill, ...] = ()

    @property
    def robot(self) -> str:
        """The harness robot name (fr3, lift2, split_aloha)."""
        return self.task.robot
