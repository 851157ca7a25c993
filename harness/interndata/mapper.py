"""Mapping one task entry of an InternDataEngine file: each ``pick`` skill -> a ``TaskConfig``.

``TaskMapper`` takes what ``TaskResolver`` read from the entry and builds one harness task per
pick skill (robot placement and home, the scene's objects, physics, the pick block). A
validation error is located at the InternData key its value came from.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pydantic import ValidationError

from harness.config.errors import ConfigError
from harness.config.task import TaskConfig
from harness.config.validation import describe_validation_error
from harness.config.yamlio import KeyPath
from harness.errors import InputFileError
from harness.interndata.distractors import distractor_objects
from harness.interndata.keys import (
    OBJECT_KEYS_IGNORED,
    TABLE_NAME,
    TASK_KEYS_IGNORED,
    TASK_KEYS_MAPPED,
)
from harness.interndata.resolver import ObjectEntry, PickSkill, TaskResolver
from harness.interndata.result import InternDataPick


class TaskMapper(TaskResolver):
    """Maps one entry of the file's ``tasks`` list."""

    def map(self, first_order: int) -> list[InternDataPick]:
        task = self.mapping(self.data, self.path, "a task")
        for key in task:
            if key in TASK_KEYS_IGNORED:
                self.note(f"ignored {self.key((*self.path, key))}: {TASK_KEYS_IGNORED[key]}")
            elif key not in TASK_KEYS_MAPPED:
                self.note(f"ignored {self.key((*self.path, key))}: not a key pick-harness reads")
        robots = self.robots(task)
        objects = self.objects(task)
        regions = self.regions(task, robots, objects)
        picks = self.skills(task, robots)
        if not picks:
            raise self.error(
                (*self.path, "skills"), "no pick skill to run (pick-harness runs pick skills)"
            )
        data_block = task.get("data", {})
        data_path = (*self.path, "data")
        if data_block is None:
            data_block = {}
        self.mapping(data_block, data_path, "data")
        for key in data_block:
            if key != "max_episode_length":
                self.note(f"ignored {self.key((*data_path, key))}: data logging")
        out = []
        file_notes = self.notes
        for order, pick in enumerate(picks, start=first_order):
            self.notes = list(file_notes)
            config = self.task_config(task, pick, objects, regions, len(picks), order)
            out.append(
                InternDataPick(
                    task=config,
                    task_index=self.index,
                    stage=pick.stage,
                    phase=pick.phase,
                    robot_name=pick.robot.name,
                    arm=pick.arm,
                    skill_index=pick.skill_index,
                    order=order,
                    key=self.key(pick.path),
                    skipped=self.notes,
                    skipped_skills=tuple(self.skipped_skills),
                )
            )
        self.notes = file_notes
        return out

    # -- the harness task -------------------------------------------------------------------------

    def task_config(
        self,
        task: dict[str, Any],
        pick: PickSkill,
        objects: dict[str, ObjectEntry],
        regions: dict[str, tuple[dict[str, Any], KeyPath]],
        pick_count: int,
        order: int,
    ) -> TaskConfig:
        origin: dict[KeyPath, KeyPath] = {(): self.path, ("pick",): pick.path}
        robot = pick.robot
        block = self.pick_block(pick, origin)
        wanted = block["objects"]
        required = {str(n) for n in wanted} if isinstance(wanted, list) else set()

        target = str(wanted[0]) if isinstance(wanted, list) and wanted else None
        object_configs: list[dict[str, Any]] = []
        for obj in objects.values():
            config = self.object_config(obj, obj.name in required, regions, origin, object_configs)
            if config is not None and obj.name == target and self.check_grasps:
                self.check_grasp_file(obj, Path(config["mesh"]), block, pick.path)
            if config is not None:
                object_configs.append(config)
        if task.get("distractors"):
            object_configs.extend(self.distractors(task["distractors"], objects))

        yaw = self.robot_yaw(robot)
        robot_placement = None
        if robot.name in regions:
            robot_placement, place_origin = self.placement(regions[robot.name], yaw, False)
            for sub, src in place_origin.items():
                origin[("robot_placement", *sub)] = src
        else:
            self.note(f"{self.key(robot.path)}: no region; robot.yaml's placement is used")
        home, std, home_path, std_path = self.home(robot, pick.arm)
        origin[("home",)] = home_path
        origin[("home_noise_std",)] = std_path

        table_contact = self.table_contact(task, origin)

        data_block = task.get("data") or {}
        max_steps = data_block.get("max_episode_length")
        origin[("max_episode_length",)] = (*self.path, "data", "max_episode_length")
        name = self.stem if pick_count == 1 else f"{self.stem}-{order}-{pick.arm}"
        data: dict[str, Any] = {
            "name": name,
            "robot": robot.harness,
            "arm": pick.arm,
            "robot_placement": robot_placement,
            "home": home,
            "home_noise_std": std,
            "objects": object_configs,
            "physics": {"table_contact": table_contact},
            "pick": block,
            "source": self.where.file,
        }
        if pick.prelude_pick is not None:
            data["handover"] = self.handover(pick, origin)
        if pick.not_runnable:
            data["not_runnable"] = pick.not_runnable
            self.note(f"not runnable in isolation: {pick.not_runnable}")
        if max_steps is not None:
            data["max_episode_length"] = max_steps
        else:
            self.note(f"{self.key((*self.path, 'data'))}: no max_episode_length; using 500")
        try:
            return TaskConfig.model_validate(data)
        except ValidationError as exc:
            raise self.translate(exc, origin) from None

    def handover(self, pick: PickSkill, origin: dict[KeyPath, KeyPath]) -> dict[str, Any]:
        """A handover's second pick: the first arm's pick block, home and goto__pose, replayed
        first in each episode (``TaskConfig.handover``, ``harness.episode.handover``)."""
        first = pick.prelude_pick
        assert first is not None
        first_origin: dict[KeyPath, KeyPath] = {}
        block = self.pick_block(first, first_origin)
        origin[("handover", "pick")] = first.path
        for sub, src in first_origin.items():
            origin[("handover", *sub)] = src
        home, std, home_path, std_path = self.home(first.robot, first.arm)
        origin[("handover", "home")] = home_path
        origin[("handover", "home_noise_std")] = std_path
        data: dict[str, Any] = {
            "arm": first.arm,
            "home": home,
            "home_noise_std": std,
            "pick": block,
            "first_key": self.key(first.path),
        }
        steps = f"{self.key(first.path)} (pick)"
        if pick.prelude_goto is not None:
            goto, goto_path = pick.prelude_goto
            data["goto_pose"] = dict(goto)
            data["goto_key"] = self.key(goto_path)
            origin[("handover", "goto_pose")] = goto_path
            steps += f" and {self.key(goto_path)} (goto__pose)"
        self.note(
            f"{self.key(pick.path)} takes the object from the {first.arm} gripper: each episode "
            f"runs {steps} first, from the same reset, then this pick from the object's pose "
            "in mid-air (a handover; docs/interndata.md)"
        )
        return data

    def distractors(self, block: Any, objects: dict[str, ObjectEntry]) -> list[dict[str, Any]]:
        """The ``distractors`` block's rigid objects (``harness.interndata.distractors``)."""
        path = (*self.path, "distractors")
        self.mapping(block, path, "distractors")
        pos_range = block.get("pos_range")
        if not (isinstance(pos_range, list) and len(pos_range) == 2):
            raise self.error((*path, "pos_range"), "expected [[x_min, y_min], [x_max, y_max]]")
        for row in pos_range:
            width = 3 if isinstance(row, list) and len(row) == 3 else 2
            self.numbers(row, (*path, "pos_range"), width)
        own = {
            Path(str(obj.config.get("path", ""))).parts[-3]
            for obj in objects.values()
            if len(Path(str(obj.config.get("path", ""))).parts) >= 3
        }
        return distractor_objects(
            block, self.asset_base(), own, self.where.file, self.note, self.key(path)
        )

    def pick_block(self, pick: PickSkill, origin: dict[KeyPath, KeyPath]) -> dict[str, Any]:
        """The pick's block, with the robot's ``ignore_substring`` as
        ``robot_ignore_substring``: it replaces the controllers' default planning-world ignore
        list (template_controller.py __init__), the pick's own list adds to it."""
        robot = pick.robot
        block = dict(pick.block)
        if "objects" not in block:
            raise self.error((*pick.path, "objects"), "a pick needs objects (the first is picked)")
        robot_ignore = robot.config.get("ignore_substring")
        if robot_ignore is not None:
            block["robot_ignore_substring"] = robot_ignore
            origin[("pick", "robot_ignore_substring")] = (*robot.path, "ignore_substring")
        return block

    def table_contact(self, task: dict[str, Any], origin: dict[KeyPath, KeyPath]) -> bool:
        """Robot-table contact, off when ``neglect_collision_names`` names the table."""
        neglect = task.get("neglect_collision_names") or []
        npath = (*self.path, "neglect_collision_names")
        if not isinstance(neglect, list):
            raise self.error(npath, f"expected a list of names, got {neglect!r}")
        table_contact = not any(isinstance(n, str) and n in TABLE_NAME for n in neglect)
        for name in neglect:
            if isinstance(name, str) and name not in TABLE_NAME:
                self.note(
                    f"{self.key(npath)}: {name!r} ignored (the harness can switch off only "
                    "robot-table contact)"
                )
        origin[("physics",)] = npath
        return table_contact

    def object_config(
        self,
        obj: ObjectEntry,
        required: bool,
        regions: dict[str, tuple[dict[str, Any], KeyPath]],
        origin: dict[KeyPath, KeyPath],
        done: list[dict[str, Any]],
    ) -> dict[str, Any] | None:
        mesh, substitute_scale, exists = self.object_mesh(obj)
        path_key = (*obj.path, "path")
        if self.check_assets and not exists:
            if required:
                hint = (
                    f"substitute it with --object {obj.name}=PATH"
                    if obj.name not in self.substitutes
                    else "check the --object path"
                )
                where = "substitute" if obj.name in self.substitutes else "asset"
                raise self.error(path_key, f"{where} not found: {mesh} ({hint})")
            self.note(
                f"skipped object {obj.name!r}: asset not found ({mesh}); it is not picked, so "
                f"the scene goes without it (give --object {obj.name}=PATH to include it)"
            )
            return None
        region = regions.get(obj.name)
        if region is None and not required:
            self.note(f"skipped object {obj.name!r}: no table region to place it by")
            return None
        for key in obj.config:
            if key in OBJECT_KEYS_IGNORED:
                self.note(f"ignored {self.key((*obj.path, key))}: {OBJECT_KEYS_IGNORED[key]}")
        target_class = obj.config.get("target_class", "RigidObject")
        fixed = target_class == "GeometryObject"  # static in the reference (geometry_object.py)
        if target_class not in ("RigidObject", "GeometryObject"):
            self.note(
                f"{self.key((*obj.path, 'target_class'))}: "
                f"{target_class} simulated as a free rigid body"
            )
        orientations, category, free_yaw = self.orientations(obj, mesh)
        index = len(done)
        base = ("objects", index)
        origin[base] = obj.path
        origin[(*base, "mesh")] = path_key
        origin[(*base, "scale")] = (*obj.path, "scale")
        origin[(*base, "orientations")] = (*obj.path, "euler")
        config: dict[str, Any] = {
            "name": obj.name,
            "mesh": mesh,
            "orientations": orientations,
        }
        if category:
            config["category"] = category
        if fixed:
            config["fixed"] = True
            origin[(*base, "fixed")] = (*obj.path, "target_class")
        if "mass" in obj.config:  # the reference passes it to its RigidPrim (rigid_object.py:43)
            config["mass"] = obj.config["mass"]
            origin[(*base, "mass")] = (*obj.path, "mass")
        if substitute_scale is not None:
            config["scale"] = substitute_scale
        elif obj.name in self.substitutes:
            config["scale"] = 1.0
            if obj.config.get("scale") not in (None, 1, [1, 1, 1]):
                self.note(
                    f"{self.key((*obj.path, 'scale'))}: substitute {obj.name!r} used at scale 1 "
                    f"(the file's {obj.config.get('scale')} belongs to its own asset; "
                    "give NAME=PATH@SCALE to set one)"
                )
        elif "scale" in obj.config:
            config["scale"] = obj.config["scale"]
        if obj.config.get("translation") not in (None, [0, 0, 0], [0.0, 0.0, 0.0]):
            self.note(f"ignored {self.key((*obj.path, 'translation'))}: its region places it")
        if region is not None:
            placement, place_origin = self.placement(region, 0.0, free_yaw)
            config["placement"] = placement
            for sub, src in place_origin.items():
                origin[(*base, "placement", *sub)] = src
        else:
            self.note(f"{obj.name!r}: no table region; the arm's object region from robot.yaml")
        return config

    def check_grasp_file(
        self, obj: ObjectEntry, mesh: Path, block: dict[str, Any], pick_path: KeyPath
    ) -> None:
        """The picked object's grasp file must exist: the pick's ``npy_name`` next to its asset
        (the reference's rule; the harness also takes ``<mesh>_grasps.npy`` or ``grasps.npy``
        for the default name). Checked here so a missing one is one located line up front, not
        an ``error`` row per episode."""
        from harness.objects.assets import DEFAULT_NPY_NAME, find_grasp_file

        npy_name = block.get("npy_name", DEFAULT_NPY_NAME)
        if not isinstance(npy_name, str) or not npy_name:
            return  # PickConfig validation reports it at the pick's npy_name
        try:
            found = find_grasp_file(mesh, npy_name)
        except InputFileError:
            found = None
        if found is not None:
            return
        if npy_name != DEFAULT_NPY_NAME:
            raise self.error(
                (*pick_path, "npy_name"),
                f"grasp file not found next to the asset of {obj.name!r}: {mesh.parent / npy_name}",
            )
        raise self.error(
            (*obj.path, "path"),
            f"no grasp file next to the asset: {mesh.parent / npy_name} (the pick reads its "
            "npy_name, default Aligned_grasp_sparse.npy, next to the USD)",
        )

    def translate(self, exc: ValidationError, origin: dict[KeyPath, KeyPath]) -> ConfigError:
        """A TaskConfig validation error, located at the InternData key the value came from."""
        loc, message, line_loc = describe_validation_error(exc, TaskConfig)

        def source(harness_path: KeyPath) -> KeyPath:
            for end in range(len(harness_path), -1, -1):
                if harness_path[:end] in origin:
                    return (*origin[harness_path[:end]], *harness_path[end:])
            return self.path

        return self.where.error(source(loc), message, source(line_loc))
