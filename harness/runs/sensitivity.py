"""The sensitivity plan: every chosen value, moved to 0.5x and 2x on its robot's canonical tasks.

A physical value without a primary source (a robot.yaml ``sources`` entry marked "chosen", with
the task key that sweeps it after "|"; a task default marked chosen: ``TASK_DEFAULTS``) is an
assumption the results rest on. ``harness sensitivity`` runs, per value, one sweep: the value at
its two off-default settings (``factors``: 0.5x and 2x, or the plausible range where 2x is not
physical) x two approach cones (the canonical ``downward 140`` and ``downward 120``, so a
change of the best setting shows) on the robot's canonical tasks (``tasks/pick/<robot>*.yaml``)
with the cube, plus one baseline sweep per task list at every default: the 1x column of every
value on those tasks. The task defaults run on one canonical arm per robot (its first task
file). The grip values of the Split ALOHA also run on the InternData example
bottle (the right arm, issue 55's slip) and the handover rule on a handover file, when given.

``plan`` lists the sweeps (a ``SweepConfig`` mapping each, written to the run folder as
``<name>.yaml``); ``uncovered`` lists the chosen values the plan cannot sweep (a
``sources`` entry without a task key): the table of docs/results.md counts them, 0 expected.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from harness.config.robot_registry import TASKS_DIR, available_robots, canonical_task_files

CONES: tuple[list[Any], ...] = (["downward", 140], ["downward", 120])
OFF_DEFAULT = (0.5, 2.0)
# Where 2x is not physical, the plausible range's ends as factors of the default.
RANGES: dict[tuple[str, str], tuple[float, float]] = {
    # arx5-sdk's ideal 85.7 N per pad is the most the R5a can squeeze; a unit calibrated to
    # gripper_open_readout 3.4 rad gives 58 N (robots/lift2/robot.yaml sources).
    ("lift2", "robot.gripper.force_limit"): (0.5, 58.0 / 85.7),
}
MOUNT_SHIFT_M = 0.05  # robot_placement: the whole robot 5 cm lower / higher


@dataclass(frozen=True)
class TaskDefault:
    """A task default without a primary source: its key, default and swept values."""

    key: str
    source: str
    default: float
    values: tuple[float, ...]
    handover: bool = False  # needs a handover task (a second pick after a release)


TASK_DEFAULTS: tuple[TaskDefault, ...] = (
    TaskDefault(
        "pick.max_slip_rotation", "harness/config/pick.py max_slip_rotation", 0.1, (0.05, 0.2)
    ),
    # 0 N: any force of the opened first gripper is a support; 0.5x / 2x of 0 are 0, so the
    # plausible range is a residual touch of 0.5 N and 2 N.
    TaskDefault(
        "pick.max_first_gripper_force",
        "harness/config/pick.py max_first_gripper_force",
        0.0,
        (0.5, 2.0),
        handover=True,
    ),
    TaskDefault("physics.noslip_iterations", "harness/config/task.py PhysicsConfig", 10, (5, 20)),
    TaskDefault("object.mass", "tasks/objects/cube (0.05 kg)", 0.05, (0.025, 0.1)),
    TaskDefault("object.friction", "harness/config/task.py ObjectConfig", 1.0, (0.5, 2.0)),
)


@dataclass(frozen=True)
class ChosenValue:
    """One chosen value: where it is declared, the key that sweeps it, its default and the
    values swept on which robot's tasks (``robot`` '' for a task default: every robot)."""

    robot: str
    source: str
    key: str
    default: Any
    values: tuple[Any, ...]
    tasks: tuple[str | dict[str, Any], ...] = field(default=())
    label: str = ""
    suffix: str = ""  # distinguishes a second sweep of the same value (the bottle)

    @property
    def name(self) -> str:
        """The sweep's (folder) name."""
        robot = self.robot or "task"
        return f"{robot}-{self.key.replace('robot.', '').replace('.', '_')}{self.suffix}"


def _gripper_default(robot: str, field_name: str) -> float:
    from harness.robots import RobotModel

    model = RobotModel.load(robot)
    first = next(iter(model.arms.values()))
    return float(getattr(first.gripper, field_name))


def _placement_values(robot: str) -> tuple[Any, tuple[Any, ...]]:
    """The robot.yaml placement and the same placement ``MOUNT_SHIFT_M`` lower and higher."""
    from harness.robots.facts import robot_file

    placement = robot_file(robot).placement.model_dump(mode="json")

    def shifted(dz: float) -> dict[str, Any]:
        low, high = placement["pos_range"]
        return {
            **placement,
            "pos_range": [[low[0], low[1], low[2] + dz], [high[0], high[1], high[2] + dz]],
        }

    return placement, (shifted(-MOUNT_SHIFT_M), shifted(MOUNT_SHIFT_M))


def robot_values(robot: str) -> tuple[list[ChosenValue], list[str]]:
    """The chosen values of ``robot``'s robot.yaml with their sweeps, and the ``sources`` keys
    that name no task key (uncovered)."""
    from harness.robots.facts import robot_file

    tasks = tuple(str(path) for path in canonical_task_files(robot))
    values: list[ChosenValue] = []
    uncovered: list[str] = []
    for source, key in robot_file(robot).unsourced().items():
        if not key:
            uncovered.append(f"{robot}: {source}")
            continue
        if key == "robot_placement.pos_range":
            default, swept = _placement_values(robot)
            values.append(
                ChosenValue(robot, source, "robot_placement", default, swept, tasks, "-5 cm, +5 cm")
            )
            continue
        if key.startswith("robot.timing."):
            default = 1.0
        elif key.startswith("robot.gripper."):
            default = _gripper_default(robot, key.removeprefix("robot.gripper."))
        else:
            uncovered.append(f"{robot}: {source} ({key}: no rule to move it)")
            continue
        low, high = RANGES.get((robot, key), OFF_DEFAULT)
        swept = (round(default * low, 6), round(default * high, 6))
        values.append(
            ChosenValue(robot, source, key, default, swept, tasks, f"{low:g}x, {high:g}x")
        )
    return values, uncovered


BOTTLE = "objects/recyclable_garbage/bottle_1/Aligned_obj.usd"
BOTTLE_KEYS = (
    "robot.gripper.force_limit",
    "robot.gripper.pad_friction",
    "robot.gripper.pad_torsion",
    "pick.max_slip_rotation",
)


def plan(
    robots: list[str] | None = None,
    examples: Path | None = None,
    handover: Path | None = None,
    handover_objects: dict[str, str] | None = None,
) -> tuple[list[ChosenValue], list[str]]:
    """Every chosen value of the bundled robots (or ``robots``) and the task defaults, with
    what the plan cannot sweep. ``examples``: the InternData example folder (the bottle runs
    of the Split ALOHA grip); ``handover``: a handover InternData file (the release rule),
    its objects substituted by ``handover_objects`` (name -> asset path)."""
    names = robots or available_robots()
    values: list[ChosenValue] = []
    uncovered: list[str] = []
    for robot in names:
        mine, missing = robot_values(robot)
        values += mine
        uncovered += missing
    # The task defaults run on one canonical arm per robot (the first task file of each).
    every_task = tuple(str(canonical_task_files(robot)[0]) for robot in names)
    for default in TASK_DEFAULTS:
        if default.handover:
            if handover is None:
                uncovered.append(f"task: {default.key} (needs --handover FILE)")
                continue
            entry: dict[str, Any] = {"interndata": str(handover.resolve())}
            if handover_objects:
                entry["objects"] = dict(handover_objects)
            tasks: tuple[str | dict[str, Any], ...] = (entry,)
        else:
            tasks = every_task
        values.append(
            ChosenValue(
                "", default.source, default.key, default.default, default.values, tasks, "range"
            )
        )
    if examples is not None and "split_aloha" in names:
        bottle = str((examples / BOTTLE).resolve())
        right = str(TASKS_DIR / "split_aloha_right.yaml")
        for value in list(values):
            if value.key in BOTTLE_KEYS and value.robot in ("split_aloha", ""):
                values.append(
                    ChosenValue(
                        "split_aloha",
                        value.source,
                        value.key,
                        value.default,
                        value.values,
                        ({"bottle": bottle, "task": right},),
                        value.label + ", bottle_1",
                        "-bottle",
                    )
                )
    # The bottle first (issue 55's slip), then the robots' values, then the task defaults
    # (the validity's bounds before the physics defaults), so a plan cut short by its budget
    # has measured the values the results lean on most.
    order = [d.key for d in TASK_DEFAULTS]

    def rank(v: ChosenValue) -> tuple[bool, bool, int]:
        return v.suffix != "-bottle", v.robot == "", order.index(v.key) if not v.robot else 0

    values.sort(key=rank)
    return values, uncovered


def _task_entries(value: ChosenValue) -> tuple[list[str | dict[str, Any]], list[str]]:
    """The sweep's task entries and object axis."""
    entries: list[str | dict[str, Any]] = []
    objects = ["cube"]
    for task in value.tasks:
        if isinstance(task, dict) and "bottle" in task:
            entries.append(task["task"])
            objects = [task["bottle"]]
        else:
            entries.append(task)
    if any(isinstance(t, dict) and "interndata" in t for t in value.tasks):
        objects = []
    return entries, objects


def sweep_of(value: ChosenValue, episodes: int, seed: int, baseline: bool = False) -> dict:
    """The sweep mapping of ``value`` (or, with ``baseline``, of its tasks at every default)."""
    entries, objects = _task_entries(value)
    axes: dict[str, list[Any]] = {}
    if objects:
        axes["object.mesh"] = objects
    if not baseline:
        axes[value.key] = list(value.values)
    axes["pick.approach_filter"] = [list(c) for c in CONES]
    return {
        "name": baseline_name(value) if baseline else value.name,
        "tasks": entries,
        "axes": axes,
        "episodes_per_point": episodes,
        "seed": seed,
        "record": "none",
    }


def baselines(values: list[ChosenValue]) -> dict[str, ChosenValue]:
    """One value per distinct task list: the sweep whose rows are the 1x column of every value
    on those tasks (keyed by the baseline's name)."""
    out: dict[str, ChosenValue] = {}
    for value in values:
        key = baseline_name(value)
        out.setdefault(key, value)
    return out


def baseline_name(value: ChosenValue) -> str:
    """The baseline run a value's 1x column comes from (one per task list)."""
    import hashlib
    import json

    digest = hashlib.sha256(json.dumps(value.tasks, sort_keys=True).encode()).hexdigest()[:8]
    return f"baseline-{digest}"


def default_examples() -> Path | None:
    """The shared InternData examples beside the repository, if there."""
    folder = TASKS_DIR.parents[1].parent / "shared" / "datasets" / "interndata-examples"
    return folder if folder.is_dir() else None
