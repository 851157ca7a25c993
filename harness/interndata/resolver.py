"""Reading one task entry of an InternDataEngine file: its robots, objects, regions and skills.

``TaskResolver`` checks each part of the entry and resolves it into plain values (robot yaw and
home, object meshes and orientations, table regions, the pick skills in execution order),
collecting notes on everything the harness does not carry. ``TaskMapper`` builds on it.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from harness.config.errors import ConfigError
from harness.config.messages import suggest
from harness.config.yamlio import KeyPath, format_key_path
from harness.interndata.categories import CATEGORY_ORIENTATIONS
from harness.interndata.dependencies import (
    SkillRef,
    handover_prelude,
    not_runnable_reason,
    skill_target,
)
from harness.interndata.errors import Located
from harness.interndata.keys import REGION_SAMPLER, ROBOT_KEYS_IGNORED, TABLE_NAME
from harness.interndata.orientations import (
    RANDOM_GRID_STEP,
    random_orientations,
    suggested_orientations,
)
from harness.interndata.result import SkippedSkill
from harness.interndata.substitutes import split_substitute
from harness.robots.facts import interndata_home, interndata_robots, robot_arms

log = logging.getLogger(__name__)


@dataclass
class RobotEntry:
    """A robot of the task entry, with the harness robot its config file names."""

    name: str  # the reference name (skills and regions use it)
    harness: str  # fr3 / lift2 / split_aloha
    path: KeyPath
    config: dict[str, Any]


@dataclass
class ObjectEntry:
    """An object of the task entry, as written in the file."""

    name: str
    path: KeyPath
    config: dict[str, Any]


@dataclass
class PickSkill:
    """A ``pick`` skill of the ``skills`` tree, with its robot, arm and position in the tree."""

    block: dict[str, Any]
    path: KeyPath
    robot: RobotEntry
    arm: str
    stage: int
    phase: int
    skill_index: int
    not_runnable: str | None = None  # harness.interndata.dependencies
    # A handover's second pick: the other arm's pick and its goto__pose (block, path), replayed
    # first in the same episode (harness.interndata.dependencies.handover_prelude).
    prelude_pick: PickSkill | None = None
    prelude_goto: tuple[dict[str, Any], KeyPath] | None = None


class TaskResolver:
    """Reads one entry of the file's ``tasks`` list (``TaskMapper`` maps it)."""

    def __init__(
        self,
        where: Located,
        data: dict[str, Any],
        index: int,
        asset_root: Path | None,
        substitutes: dict[str, str],
        check_assets: bool,
        check_grasps: bool = False,
    ) -> None:
        self.where = where
        self.index = index
        self.path: KeyPath = ("tasks", index)
        self.data = data
        self.asset_root = asset_root
        self.substitutes = substitutes
        self.check_assets = check_assets
        self.check_grasps = check_assets and check_grasps
        self.notes: list[str] = []  # the file's notes, then (during task_config) one pick's
        self.skipped_skills: list[SkippedSkill] = []
        self.stem = Path(where.file).stem

    # -- helpers --------------------------------------------------------------------------------

    def error(self, path: KeyPath, message: str) -> ConfigError:
        return self.where.error(path, message)

    def note(self, text: str) -> None:
        if text not in self.notes:
            self.notes.append(text)

    def mapping(self, value: Any, path: KeyPath, what: str) -> dict[str, Any]:
        if not isinstance(value, dict):
            raise self.error(path, f"expected a mapping ({what}), got {type(value).__name__}")
        return value

    def sequence(self, value: Any, path: KeyPath, what: str) -> list[Any]:
        if not isinstance(value, list):
            raise self.error(path, f"expected a list ({what}), got {type(value).__name__}")
        return value

    def key(self, path: KeyPath) -> str:
        return format_key_path(path)

    # -- robots -----------------------------------------------------------------------------------

    def robots(self, task: dict[str, Any]) -> dict[str, RobotEntry]:
        path = (*self.path, "robots")
        if "robots" not in task:
            raise self.error(path, "required key is missing")
        robots: dict[str, RobotEntry] = {}
        for i, robot in enumerate(self.sequence(task["robots"], path, "robots")):
            rpath = (*path, i)
            robot = self.mapping(robot, rpath, "a robot")
            name = robot.get("name")
            if not isinstance(name, str) or not name:
                raise self.error((*rpath, "name"), "a robot needs a name")
            if name in robots:
                raise self.error((*rpath, "name"), f"robot name {name!r} repeats")
            config_file = robot.get("robot_config_file")
            if not isinstance(config_file, str):
                raise self.error((*rpath, "robot_config_file"), "required key is missing")
            basename = Path(config_file).name
            supported = interndata_robots()
            if basename not in supported:
                raise self.error(
                    (*rpath, "robot_config_file"),
                    f"unsupported robot {basename!r} ({config_file}); supported: "
                    f"{', '.join(supported.values())}",
                )
            for key in robot:
                if key in ROBOT_KEYS_IGNORED:
                    self.note(f"ignored {self.key((*rpath, key))}: {ROBOT_KEYS_IGNORED[key]}")
            robots[name] = RobotEntry(name, supported[basename], rpath, robot)
        if not robots:
            raise self.error(path, "no robots")
        if len(robots) > 1:
            self.note(
                f"robots {list(robots)}: each harness task simulates only the robot that picks"
            )
        return robots

    def robot_yaw(self, robot: RobotEntry) -> float:
        euler = robot.config.get("euler")
        if euler is None:
            if robot.config.get("quaternion") is not None:
                raise self.error(
                    (*robot.path, "quaternion"), "robot quaternion is not supported; use euler"
                )
            return 0.0
        path = (*robot.path, "euler")
        values = self.numbers(euler, path, 3)
        if abs(values[0]) > 1e-9 or abs(values[1]) > 1e-9:
            raise self.error(
                path,
                f"robot euler must be a pure yaw [0, 0, yaw] (the robot stands on the "
                f"floor or table), got {values}",
            )
        return values[2]

    def home(self, robot: RobotEntry, arm: str) -> tuple[Any, Any, KeyPath, KeyPath]:
        home_key, std_key = f"{arm}_joint_home", f"{arm}_joint_home_std"
        home = robot.config.get(home_key)
        std = robot.config.get(std_key)
        if home is None:
            home = interndata_home(robot.harness, arm)
            self.note(
                f"{self.key(robot.path)}: no {home_key}; using the reference robot file's "
                f"home {home}"
            )
        if std is None:
            std = [0.0] * len(home) if isinstance(home, list) else None
        return home, std, (*robot.path, home_key), (*robot.path, std_key)

    # -- objects ----------------------------------------------------------------------------------

    def objects(self, task: dict[str, Any]) -> dict[str, ObjectEntry]:
        path = (*self.path, "objects")
        objects: dict[str, ObjectEntry] = {}
        for i, obj in enumerate(self.sequence(task.get("objects", []), path, "objects")):
            opath = (*path, i)
            obj = self.mapping(obj, opath, "an object")
            name = obj.get("name")
            if not isinstance(name, str) or not name:
                raise self.error((*opath, "name"), "an object needs a name")
            if name in objects:
                raise self.error((*opath, "name"), f"object name {name!r} repeats")
            objects[name] = ObjectEntry(name, opath, obj)
        return objects

    def asset_base(self) -> Path:
        if self.asset_root is not None:
            return Path(self.asset_root)
        root = self.data.get("asset_root")
        if isinstance(root, str) and root:
            return Path(root)  # as the reference: relative to the current directory
        return Path(self.where.file).resolve().parent

    def object_mesh(self, obj: ObjectEntry) -> tuple[str, tuple[float, float, float] | None, bool]:
        """(mesh path, substitute scale or None, asset exists)."""
        if obj.name in self.substitutes:
            mesh, scale = split_substitute(self.substitutes[obj.name])
            substitute = Path(mesh).expanduser().absolute()  # relative to the current directory
            return str(substitute), scale, substitute.is_file()
        raw = obj.config.get("path")
        if not isinstance(raw, str) or not raw:
            raise self.error((*obj.path, "path"), "an object needs a path (its USD file)")
        if not self.check_assets and self.asset_root is None:
            return raw, None, True
        full = (Path(raw) if Path(raw).is_absolute() else self.asset_base() / raw).absolute()
        return str(full), None, full.is_file()

    def numbers(self, value: Any, path: KeyPath, count: int) -> list[float]:
        if (
            not isinstance(value, list)
            or len(value) != count
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
        ):
            raise self.error(path, f"expected {count} numbers, got {value!r}")
        return [float(v) for v in value]

    def orientations(
        self, obj: ObjectEntry, mesh: str
    ) -> tuple[list[tuple[float, float, float]], str | None, bool]:
        """(base orientations, category used, yaw is free) for one object."""
        config = obj.config
        quaternion = config.get("quaternion")
        if config.get("euler") is not None:
            euler = tuple(self.numbers(config["euler"], (*obj.path, "euler"), 3))
        elif quaternion is not None:
            euler = self.quaternion_euler(quaternion, (*obj.path, "quaternion"))
        else:
            euler = (0.0, 0.0, 0.0)
        mode = config.get("orientation_mode", "keep")
        randomized = bool(config.get("apply_randomization", False))
        rigid = config.get("target_class", "RigidObject") == "RigidObject"
        if mode not in ("keep", "suggested", "random"):
            raise self.error(
                (*obj.path, "orientation_mode"),
                f"unknown orientation_mode {mode!r}; the reference knows keep, suggested, random",
            )
        if not (randomized and rigid) or mode == "keep":
            return [euler], config.get("category"), False  # type: ignore[list-item]
        if mode == "random":
            self.note(
                f"{self.key((*obj.path, 'orientation_mode'))}: random -> x, y on a "
                f"{RANDOM_GRID_STEP} deg grid, free yaw (the reference draws them continuously)"
            )
            return random_orientations(), config.get("category"), True
        parts = Path(mesh).parts
        category = parts[-3] if len(parts) >= 3 else ""
        if category not in CATEGORY_ORIENTATIONS:
            self.note(
                f"{self.key((*obj.path, 'orientation_mode'))}: category {category!r} (the "
                f"asset's grandparent folder, as the reference) is not in the orientation "
                f"table; using [0, 0, 0] as the reference does"
            )
        return suggested_orientations(category), category, False

    def quaternion_euler(self, value: Any, path: KeyPath) -> tuple[float, float, float]:
        from scipy.spatial.transform import Rotation

        w, x, y, z = self.numbers(value, path, 4)
        if math.sqrt(w * w + x * x + y * y + z * z) < 1e-9:
            raise self.error(path, "quaternion must not be zero")
        rx, ry, rz = Rotation.from_quat([x, y, z, w]).as_euler("xyz", degrees=True)
        return (float(rx), float(ry), float(rz))

    # -- regions ----------------------------------------------------------------------------------

    def regions(
        self, task: dict[str, Any], robots: dict[str, RobotEntry], objects: dict[str, ObjectEntry]
    ) -> dict[str, tuple[dict[str, Any], KeyPath]]:
        """Object or robot name -> (random_config, region path), for usable regions."""
        path = (*self.path, "regions")
        out: dict[str, tuple[dict[str, Any], KeyPath]] = {}
        for i, region in enumerate(self.sequence(task.get("regions", []), path, "regions")):
            rpath = (*path, i)
            region = self.mapping(region, rpath, "a region")
            name = region.get("object")
            if not isinstance(name, str) or (name not in objects and name not in robots):
                known = [*objects, *robots]
                raise self.error(
                    (*rpath, "object"),
                    f"region for unknown object {name!r}{suggest(str(name), known)} "
                    f"(objects and robots: {known})",
                )
            kind = region.get("random_type")
            target = region.get("target")
            if kind != REGION_SAMPLER or not isinstance(target, str) or TABLE_NAME not in target:
                self.note(
                    f"skipped {self.key(rpath)}: only {REGION_SAMPLER} regions on the table are "
                    f"mapped (got {kind} on {target!r})"
                )
                continue
            config = self.mapping(
                region.get("random_config"), (*rpath, "random_config"), "random_config"
            )
            if name in out:
                self.note(f"{self.key(rpath)}: a later region for {name!r} replaces the earlier")
            out[name] = (config, (*rpath, "random_config"))
        return out

    def placement(
        self, region: tuple[dict[str, Any], KeyPath], yaw_offset: float, free_yaw: bool
    ) -> tuple[dict[str, Any], dict[KeyPath, KeyPath]]:
        config, path = region
        pos_range = config.get("pos_range")
        yaw = config.get("yaw_rotation", [0.0, 0.0])
        if pos_range is None:
            raise self.error((*path, "pos_range"), "required key is missing")
        if free_yaw:
            yaw_range: Any = [-180.0, 180.0]
        elif (
            isinstance(yaw, list)
            and len(yaw) == 2
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in yaw)
        ):
            yaw_range = [yaw_offset + float(yaw[0]), yaw_offset + float(yaw[1])]
        else:
            yaw_range = yaw  # let validation report it, at yaw_rotation
        origin = {
            ("pos_range",): (*path, "pos_range"),
            ("yaw_range",): (*path, "yaw_rotation"),
            (): path,
        }
        return {"pos_range": pos_range, "yaw_range": yaw_range}, origin

    # -- skills -----------------------------------------------------------------------------------

    def skills(self, task: dict[str, Any], robots: dict[str, RobotEntry]) -> list[PickSkill]:
        path = (*self.path, "skills")
        if "skills" not in task:
            raise self.error(path, "required key is missing")
        picks: list[PickSkill] = []
        refs: list[SkillRef] = []
        skipped: dict[str, int] = {}
        blocks: dict[str, tuple[dict[str, Any], KeyPath]] = {}
        for stage, stage_block in enumerate(self.sequence(task["skills"], path, "skills")):
            spath = (*path, stage)
            stage_block = self.mapping(stage_block, spath, "{robot name: [phases]}")
            for robot_name, phases in stage_block.items():
                rpath = (*spath, robot_name)
                if robot_name not in robots:
                    raise self.error(
                        rpath,
                        f"skills for unknown robot {robot_name!r}"
                        f"{suggest(str(robot_name), robots)} (robots: {list(robots)})",
                    )
                robot = robots[robot_name]
                for phase, arms in enumerate(self.sequence(phases, rpath, "phases")):
                    ppath = (*rpath, phase)
                    arms = self.mapping(arms, ppath, "{left|right: [skills]}")
                    for arm, skill_list in arms.items():
                        apath = (*ppath, arm)
                        if arm not in robot_arms(robot.harness):
                            raise self.error(
                                apath,
                                f"{robot.harness} has no arm {arm!r} "
                                f"(arms: {', '.join(robot_arms(robot.harness))})",
                            )
                        for k, skill in enumerate(self.sequence(skill_list, apath, "skills")):
                            kpath = (*apath, k)
                            skill = self.mapping(skill, kpath, "a skill")
                            name = skill.get("name")
                            blocks[self.key(kpath)] = (skill, kpath)
                            refs.append(
                                SkillRef(
                                    *(stage, robot.name, phase, str(arm), k),
                                    *(self.key(kpath), str(name), skill_target(skill)),
                                )
                            )
                            if name == "pick":
                                picks.append(PickSkill(skill, kpath, robot, arm, stage, phase, k))
                                continue
                            skipped[str(name)] = skipped.get(str(name), 0) + 1
                            mode = skill.get("mode")
                            self.skipped_skills.append(
                                SkippedSkill(
                                    self.key(kpath),
                                    str(name),
                                    robot.name,
                                    str(arm),
                                    str(mode) if mode is not None else None,
                                )
                            )
                            self.note(
                                f"skipped {self.key(kpath)}: skill {name!r} (pick-harness runs "
                                "pick skills only; each pick starts from the initial scene)"
                            )
        by_key = {self.key(pick.path): pick for pick in picks}
        for pick, ref in zip(picks, [r for r in refs if r.name == "pick"], strict=True):
            pick.not_runnable = not_runnable_reason(ref, refs)
            prelude = handover_prelude(ref, refs)
            if prelude is not None:
                pick.prelude_pick = by_key[prelude.pick.key]
                if prelude.goto is not None:
                    pick.prelude_goto = blocks[prelude.goto.key]
        for name, count in skipped.items():
            log.warning(
                "%s: skipping %d %r skill(s); pick-harness runs pick skills only",
                self.where.file,
                count,
                name,
            )
        return picks
