"""InternDataEngine task YAML -> harness tasks, one per ``pick`` skill.

People who generate data with InternDataEngine already have task files (robots, objects, regions,
a tree of skills). ``load_interndata_tasks`` reads such a file as it is and turns every ``pick``
skill into a :class:`~harness.config.models.TaskConfig` for its robot arm, so filters can be tuned
here and the numbers carried back. The mapping, key by key, is in ``docs/interndata.md``; in short:

- OmegaConf interpolations (``${tasks.0.robots.0.name}``, relative ``${.x}``, nested
  ``${a.${b}}``) are resolved first, over the whole file, as the reference's
  ``OmegaConf.to_container(resolve=True)`` does; a broken one is an error naming its key.
- Robots by ``robot_config_file`` basename (fr3, lift2, split_aloha). ``euler`` yaw plus the
  robot's ``A_on_B_region_sampler`` region -> ``robot_placement`` (root position in the world,
  origin at the table-top centre; absolute yaw). ``<arm>_joint_home`` / ``_std`` -> ``home`` /
  ``home_noise_std``; without them the reference robot file's home (no noise) is used, as the
  reference does.
- Objects by ``path`` under the asset root, or substituted (``objects={name: path}``); ``scale``,
  ``euler``, ``orientation_mode`` (``suggested``: per-category table; ``random``: a 30 degree
  grid over x and y with a free yaw) and the object's region -> ``Placement``.
- The ``skills`` tree (stages -> robot -> phases -> arm -> skills): every ``pick`` becomes a task
  in execution order, its block passed to ``PickConfig`` unchanged; other skills are skipped with
  a warning, rendering keys ignored with a note.

Errors are ``ConfigError`` lines ``file:line key.path: message`` naming the InternData file and
the key in it (``tasks[0].objects[0].path``), whatever harness key the value ended up in.
"""

from __future__ import annotations

import difflib
import itertools
import logging
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from harness.config.models import ConfigError, TaskConfig, describe_validation_error, read_yaml
from harness.config.yamlio import KeyPath, YamlDocument, format_key_path

log = logging.getLogger(__name__)

# --------------------------------------------------------------------------------------------
# Reference facts


def _suggest(name: str, valid: Any) -> str:
    close = difflib.get_close_matches(str(name), [str(v) for v in valid], n=1, cutoff=0.5)
    return f"; did you mean {close[0]!r}?" if close else ""


SUPPORTED_ROBOTS: dict[str, str] = {
    "fr3.yaml": "fr3",
    "lift2.yaml": "lift2",
    "split_aloha.yaml": "split_aloha",
}
ROBOT_ARMS: dict[str, tuple[str, ...]] = {
    "fr3": ("left",),
    "lift2": ("left", "right"),
    "split_aloha": ("left", "right"),
}
# Home of each arm in the reference robot config files (robots_*.yaml,
# docs/reference-pick-skill.md section 3),
# used when a task file does not override it. Their home noise std is zero.
REFERENCE_ROBOT_HOMES: dict[str, list[float]] = {
    "fr3": [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785],
    "lift2": [0.0] * 6,
    "split_aloha": [0.0] * 6,
}
REGION_SAMPLER = "A_on_B_region_sampler"
# The reference's neglect_collision_names entries are matched as substrings of scene names; the
# harness table is named "table" like the reference's table fixture.
TABLE_NAME = "table"
RANDOM_GRID_STEP = 30  # degrees: orientation_mode random -> x, y in {-180, -150, ..., 150}

# Category -> allowed Euler angles (degrees, extrinsic xyz) per axis, for orientation_mode
# "suggested". The facts are the reference's per-category table (simbox/core/utils/constants.py,
# CATEGORIES), regrouped here by rule. A category draws one value per listed axis, uniformly and
# independently, i.e. uniformly over the product; axes not listed stay 0; categories not listed
# get [0, 0, 0] (the reference prints a warning and does the same).
_GOOGLE_SCAN_X90 = (
    "dinosaur",
    "garage_kit",
    "hat",
    "toy_animals",
    "toy_boat",
    "toy_bus",
    "toy_car",
    "toy_plane",
    "toy_train",
    "toy_truck",
)
_OMNIOBJECT3D_X90 = (
    "bowl",
    "chess",
    "chinese_chess",
    "clock",
    "cup",
    "dinosaur",
    "dish",
    "donut",
    "dumpling",
    "egg_tart",
    "eraser",
    "facial_cream",
    "garage_kit",
    "garlic",
    "glasses",
    "hamburger",
    "hot_dog",
    "mangosteen",
    "mooncake",
    "mouse",
    "mug",
    "onion",
    "orange",
    "pastry",
    "pineapple",
    "pitaya",
    "pomegranate",
    "power_strip",
    "red_wine_glass",
    "shoe",
    "starfish",
    "teapot",
    "tomato",
    "toy_animals",
    "toy_boat",
    "toy_bus",
    "toy_car",
    "toy_plane",
    "toy_plant",
    "toy_train",
    "toy_truck",
    "waffle",
)
_PLAIN_X90 = (
    "basket",
    "bolt",
    "bowl",
    "box",
    "dirt",
    "dish",
    "drawing",
    "flower_pot",
    "microwaveoven",
    "pad",
    "pan",
    "projector",
)
_CATEGORY_RULES: list[tuple[dict[str, tuple[float, ...]], tuple[str, ...]]] = [
    (
        {"x": (0, 180)},
        (
            "google_scan-medicine_bottle",
            "omniobject3d-banana",
            "omniobject3d-bottle",
            "omniobject3d-carrot",
            "omniobject3d-chili",
            "omniobject3d-corn",
            "omniobject3d-cucumber",
            "omniobject3d-flash_light",
            "omniobject3d-hair_dryer",
            "omniobject3d-hammer",
            "omniobject3d-pen",
            "omniobject3d-sausage",
            "omniobject3d-sweet_potato",
            "omniobject3d-umbrella",
            "omniobject3d-watch",
        ),
    ),
    (
        {"x": (0, 90)},
        (
            "google_scan-bottle",
            "google_scan-mug",
            "omniobject3d-battery",
            "omniobject3d-cake",
            "omniobject3d-can",
            "omniobject3d-candle",
            "phocal-can",
        ),
    ),
    (
        {"x": (0, 90, 180)},
        (
            "omniobject3d-medicine_bottle",
            "omniobject3d-shampoo",
            "phocal-bottle",
            "phocal-shampoo",
        ),
    ),
    (
        {"x": (0, 90, 180, 270)},
        (
            "google_scan-clock",
            "google_scan-shoe",
            "omniobject3d-boxed_beverage",
            "omniobject3d-soap",
            "omniobject3d-tissue",
            "real-camera",
        ),
    ),
    (
        {"x": (90, 270)},
        (
            "google_scan-handbag",
            "omniobject3d-belt",
            "omniobject3d-bread",
            "omniobject3d-glasses_case",
            "omniobject3d-spanner",
            "omniobject3d-table_tennis_bat",
        ),
    ),
    (
        {"x": (0,)},
        (
            "omniobject3d-asparagus",
            "omniobject3d-bamboo_shoots",
            "omniobject3d-calculator",
            "omniobject3d-chicken_leg",
            "omniobject3d-conch",
            "omniobject3d-egg",
            "omniobject3d-hand_cream",
            "omniobject3d-lemon",
            "omniobject3d-lipstick",
            "omniobject3d-lotus_root",
            "omniobject3d-mango",
            "omniobject3d-peach",
            "omniobject3d-pear",
            "omniobject3d-rubik_cube",
            "omniobject3d-rubik_cube-old",
            "omniobject3d-shrimp",
            "omniobject3d-tape_measure",
            "omniobject3d-toy_motorcycle",
        ),
    ),
    (
        {"x": (90,)},
        (
            *(f"google_scan-{name}" for name in _GOOGLE_SCAN_X90),
            *(f"omniobject3d-{name}" for name in _OMNIOBJECT3D_X90),
            *(f"phocal-{name}" for name in ("cup", "mug", "red_wine_glass", "teapot")),
            *_PLAIN_X90,
        ),
    ),
    (
        {"y": (0, 90, 180, 270)},
        (
            "book",
            "google_scan-book",
            "omniobject3d-book",
            "omniobject3d-brush",
            "omniobject3d-razor",
            "omniobject3d-tooth_brush",
            "omniobject3d-tooth_paste",
            "phocal-spoon",
        ),
    ),
    ({"y": (90, 270)}, ("omniobject3d-knife", "omniobject3d-scissor")),
    ({"y": (270,)}, ("omniobject3d-remote_control", "omniobject3d-timer", "phocal-remote_control")),
    ({"x": (90,), "y": (0,), "z": (0,)}, ("plate",)),
    ({"x": (90,), "y": (0,), "z": (90,)}, ("pnp_basket",)),
]
CATEGORY_ORIENTATIONS: dict[str, dict[str, tuple[float, ...]]] = {
    name: rule for rule, names in _CATEGORY_RULES for name in names
}


def suggested_orientations(category: str) -> list[tuple[float, float, float]]:
    """Every base orientation (x, y, z Euler degrees) a category may take, equally likely."""
    rule = CATEGORY_ORIENTATIONS.get(category, {})
    axes = [rule.get(axis, (0,)) for axis in "xyz"]
    return [(float(x), float(y), float(z)) for x, y, z in itertools.product(*axes)]


def random_orientations(step: int = RANDOM_GRID_STEP) -> list[tuple[float, float, float]]:
    """``orientation_mode: random`` on a grid: x, y in [-180, 180) every ``step`` degrees, z 0.

    The reference draws x, y, z ~ U(-180, 180) and then the region's yaw on top; since a uniform
    z composed with any yaw is uniform, z = 0 with a full-circle yaw range is the same
    distribution, and only x, y are discretised.
    """
    angles = [float(a) for a in range(-180, 180, step)]
    return [(x, y, 0.0) for x in angles for y in angles]


# Keys of a task entry, with what happens to them (docs/interndata.md has the full table).
TASK_KEYS_MAPPED = ("robots", "objects", "regions", "skills", "data", "neglect_collision_names")
TASK_KEYS_IGNORED: dict[str, str] = {
    "name": "the harness names tasks after the file",
    "asset_root": "replaced by the asset_root argument (--asset-root) when one is given",
    "task": "task class; the harness has one pick episode",
    "task_id": "bookkeeping",
    "offset": "task offset in a multi-task stage",
    "render": "rendering",
    "arena_file": "arena (table, room) assets; the harness uses its own table",
    "env_map": "rendering (lighting)",
    "cameras": "rendering (cameras)",
    "distractors": "visual distractors; not simulated",
    "random_region_list": "not used by the single-pick tasks",
}
ROBOT_KEYS_IGNORED: dict[str, str] = {
    "target_class": "robot class; the harness robot comes from robot_config_file",
    "translation": "the robot's region sets its position",
    "constrain_grasp_approach": "no effect in the reference (the pose-cost metric is reset)",
    "collision_activation_distance": "cuRobo planning setting",
    "use_batch": "the harness tests candidates sequentially (the reference default)",
    "lift_home": "the lift home comes from robots/lift2/robot.yaml (0.46, the reference value)",
}
OBJECT_KEYS_IGNORED: dict[str, str] = {
    "dataset": "bookkeeping",
    "prim_path_child": "USD prim under the file's root; the harness reads the file's mesh",
    "optimize_2d_layout": "objects are placed independently (no overlap optimisation)",
    "randomization_scope": "one asset per object (no instance randomisation)",
    "texture": "rendering",
    "visible": "rendering",
    "gap": "used by place skills",
}


# --------------------------------------------------------------------------------------------
# Result


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


# --------------------------------------------------------------------------------------------
# Interpolation


class _Located:
    """Raise located ConfigErrors against one document."""

    def __init__(self, doc: YamlDocument, file: str) -> None:
        self.doc = doc
        self.file = file

    def error(self, path: KeyPath, message: str, line_path: KeyPath | None = None) -> ConfigError:
        line = self.doc.line_of(line_path if line_path is not None else path)
        key = format_key_path(path) if path else None
        return ConfigError(message, file=self.file, line=line, key=key)


_MISSING = object()


class _Resolver:
    """OmegaConf-style ``${...}`` interpolation over plain YAML data.

    Supported: absolute dotted paths with list indices (``tasks.0.robots.0.name`` or
    ``tasks[0].robots[0].name``), relative paths (``${.sibling}``, ``${..uncle}``), nested
    interpolations in the key (``${a.${b}}``), interpolations whose target is itself interpolated,
    ``\\${`` for a literal ``${``. A string that is exactly one interpolation takes the target's
    value and type; otherwise targets are formatted into the string. Resolvers (``${oc.env:X}``)
    are not supported.
    """

    def __init__(self, root: Any, where: _Located) -> None:
        self.root = root
        self.where = where
        self.active: list[KeyPath] = []  # strings being resolved, to catch cycles

    def resolve(self, node: Any, path: KeyPath = ()) -> Any:
        if isinstance(node, dict):
            return {key: self.resolve(value, (*path, key)) for key, value in node.items()}
        if isinstance(node, list):
            return [self.resolve(value, (*path, index)) for index, value in enumerate(node)]
        if isinstance(node, str) and "${" in node:
            return self._string(node, path)
        return node

    def _string(self, text: str, path: KeyPath) -> Any:
        if path in self.active:
            cycle = " -> ".join(format_key_path(p) for p in [*self.active, path])
            raise self.where.error(path, f"interpolation cycle: {cycle}")
        self.active.append(path)
        try:
            pieces = self._split(text, path)
            if len(pieces) == 1 and isinstance(pieces[0], tuple):
                return self._lookup(pieces[0][0], path)
            out = []
            for piece in pieces:
                if isinstance(piece, str):
                    out.append(piece)
                    continue
                value = self._lookup(piece[0], path)
                if isinstance(value, (dict, list)):
                    raise self.where.error(
                        path,
                        f"interpolation ${{{piece[0]}}} is a {type(value).__name__}; "
                        "only a whole string can take a mapping or list",
                    )
                out.append(str(value))
            return "".join(out)
        finally:
            self.active.pop()

    def _split(self, text: str, path: KeyPath) -> list[str | tuple[str]]:
        """Literal text and ``(expression,)`` pieces; nested ``${}`` inside an expression are
        resolved to text first."""
        pieces: list[str | tuple[str]] = []
        literal = ""
        index = 0
        while index < len(text):
            if text.startswith("\\${", index):
                literal += "${"
                index += 3
            elif text.startswith("${", index):
                end, expression = self._expression(text, index + 2, path)
                if literal:
                    pieces.append(literal)
                    literal = ""
                pieces.append((expression,))
                index = end
            else:
                literal += text[index]
                index += 1
        if literal:
            pieces.append(literal)
        return pieces

    def _expression(self, text: str, start: int, path: KeyPath) -> tuple[int, str]:
        """Read up to the matching ``}``; returns (index after it, expression with inner
        interpolations resolved)."""
        out = ""
        index = start
        while index < len(text):
            if text.startswith("${", index):
                end, inner = self._expression(text, index + 2, path)
                value = self._lookup(inner, path)
                if isinstance(value, (dict, list)):
                    raise self.where.error(path, f"nested interpolation ${{{inner}}} is not a key")
                out += str(value)
                index = end
            elif text[index] == "}":
                return index + 1, out.strip()
            else:
                out += text[index]
                index += 1
        raise self.where.error(path, f"unterminated interpolation in {text!r} (missing '}}')")

    def _lookup(self, expression: str, path: KeyPath) -> Any:
        if not expression:
            raise self.where.error(path, "empty interpolation ${}")
        if ":" in expression:
            name = expression.split(":", 1)[0]
            raise self.where.error(
                path, f"interpolation ${{{expression}}}: resolver {name!r} is not supported"
            )
        dots = len(expression) - len(expression.lstrip("."))
        body = expression[dots:]
        if dots:  # relative: one dot is the node holding this string, each more goes up
            base: KeyPath = path[: max(0, len(path) - dots)]
        else:
            base = ()
        parts = [p for p in re.split(r"\.|\[|\]", body) if p != ""] if body else []
        if (body and not parts) or re.search(r"\.\.|\[\]", body):
            raise self.where.error(path, f"interpolation ${{{expression}}} is not a key path")
        node: Any = self.root
        walked: list[str | int] = []
        for step in (*base, *parts):
            value = self._child(node, step)
            if value is _MISSING:
                if isinstance(node, list) and str(step).lstrip("-").isdigit():
                    step = int(step)
                shown = format_key_path((*walked, step))
                raise self.where.error(
                    path,
                    f"interpolation ${{{expression}}}: key {shown!r} not found"
                    f"{self._hint(node, step)}",
                )
            walked.append(int(step) if isinstance(node, list) else step)
            node = value
        target = tuple(walked)
        if isinstance(node, str) and "${" in node:
            return self._string(node, target)
        return self.resolve(node, target)

    @staticmethod
    def _child(node: Any, step: str | int) -> Any:
        if isinstance(node, dict):
            if step in node:
                return node[step]
            if isinstance(step, str) and step.lstrip("-").isdigit() and int(step) in node:
                return node[int(step)]
            return _MISSING
        if isinstance(node, list):
            try:
                index = int(step)
            except ValueError:
                return _MISSING
            return node[index] if 0 <= index < len(node) else _MISSING
        return _MISSING

    @staticmethod
    def _hint(node: Any, step: str | int) -> str:
        if isinstance(node, dict):
            return _suggest(str(step), [str(k) for k in node]) or f" (keys: {list(node)[:8]})"
        if isinstance(node, list):
            return f" (the list has {len(node)} items)"
        return f" ({type(node).__name__} has no keys)"


def resolve_interpolations(doc: YamlDocument, file: str | Path | None = None) -> Any:
    """The document's data with every ``${...}`` resolved (see ``_Resolver``)."""
    where = _Located(doc, str(file if file is not None else doc.path))
    return _Resolver(doc.data, where).resolve(doc.data)


# --------------------------------------------------------------------------------------------
# Object substitution


def parse_object_substitutions(items: list[str] | tuple[str, ...]) -> dict[str, str]:
    """``["NAME=PATH", "NAME=PATH@SCALE", ...]`` (``--object``) -> ``{NAME: value}``."""
    out: dict[str, str] = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name.strip() or not value.strip():
            raise ConfigError(f"--object {item!r}: expected NAME=PATH (or NAME=PATH@SCALE)")
        out[name.strip()] = value.strip()
    return out


def split_substitute(value: str) -> tuple[str, tuple[float, float, float] | None]:
    """``PATH`` or ``PATH@S`` / ``PATH@SX,SY,SZ`` -> (path, scale or None)."""
    path, sep, suffix = value.rpartition("@")
    if not sep:
        return value, None
    try:
        numbers = [float(part) for part in suffix.split(",")]
    except ValueError:
        return value, None  # an '@' that belongs to the path
    if len(numbers) == 1:
        numbers *= 3
    if len(numbers) != 3 or not all(math.isfinite(n) and n > 0 for n in numbers):
        raise ConfigError(f"--object {value!r}: scale must be one or three positive numbers")
    return path, (numbers[0], numbers[1], numbers[2])


# --------------------------------------------------------------------------------------------
# Mapping


@dataclass
class _Robot:
    name: str  # the reference name (skills and regions use it)
    harness: str  # fr3 / lift2 / split_aloha
    path: KeyPath
    config: dict[str, Any]


@dataclass
class _Object:
    name: str
    path: KeyPath
    config: dict[str, Any]


@dataclass
class _PickSkill:
    block: dict[str, Any]
    path: KeyPath
    robot: _Robot
    arm: str
    stage: int
    phase: int
    skill_index: int


class _TaskMapper:
    """Maps one entry of the file's ``tasks`` list."""

    def __init__(
        self,
        where: _Located,
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

    # -- the task ---------------------------------------------------------------------------------

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

    # -- robots -----------------------------------------------------------------------------------

    def robots(self, task: dict[str, Any]) -> dict[str, _Robot]:
        path = (*self.path, "robots")
        if "robots" not in task:
            raise self.error(path, "required key is missing")
        robots: dict[str, _Robot] = {}
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
            if basename not in SUPPORTED_ROBOTS:
                raise self.error(
                    (*rpath, "robot_config_file"),
                    f"unsupported robot {basename!r} ({config_file}); supported: "
                    f"{', '.join(SUPPORTED_ROBOTS.values())}",
                )
            for key in robot:
                if key in ROBOT_KEYS_IGNORED:
                    self.note(f"ignored {self.key((*rpath, key))}: {ROBOT_KEYS_IGNORED[key]}")
            robots[name] = _Robot(name, SUPPORTED_ROBOTS[basename], rpath, robot)
        if not robots:
            raise self.error(path, "no robots")
        if len(robots) > 1:
            self.note(
                f"robots {list(robots)}: each harness task simulates only the robot that picks"
            )
        return robots

    def robot_yaw(self, robot: _Robot) -> float:
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

    def home(self, robot: _Robot, arm: str) -> tuple[Any, Any, KeyPath, KeyPath]:
        home_key, std_key = f"{arm}_joint_home", f"{arm}_joint_home_std"
        home = robot.config.get(home_key)
        std = robot.config.get(std_key)
        if home is None:
            home = list(REFERENCE_ROBOT_HOMES[robot.harness])
            self.note(
                f"{self.key(robot.path)}: no {home_key}; using the reference robot file's "
                f"home {home}"
            )
        if std is None:
            std = [0.0] * len(home) if isinstance(home, list) else None
        return home, std, (*robot.path, home_key), (*robot.path, std_key)

    # -- objects ----------------------------------------------------------------------------------

    def objects(self, task: dict[str, Any]) -> dict[str, _Object]:
        path = (*self.path, "objects")
        objects: dict[str, _Object] = {}
        for i, obj in enumerate(self.sequence(task.get("objects", []), path, "objects")):
            opath = (*path, i)
            obj = self.mapping(obj, opath, "an object")
            name = obj.get("name")
            if not isinstance(name, str) or not name:
                raise self.error((*opath, "name"), "an object needs a name")
            if name in objects:
                raise self.error((*opath, "name"), f"object name {name!r} repeats")
            objects[name] = _Object(name, opath, obj)
        return objects

    def asset_base(self) -> Path:
        if self.asset_root is not None:
            return Path(self.asset_root)
        root = self.data.get("asset_root")
        if isinstance(root, str) and root:
            return Path(root)  # as the reference: relative to the current directory
        return Path(self.where.file).resolve().parent

    def object_mesh(self, obj: _Object) -> tuple[str, tuple[float, float, float] | None, bool]:
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
        self, obj: _Object, mesh: str
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
        self, task: dict[str, Any], robots: dict[str, _Robot], objects: dict[str, _Object]
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
                    f"region for unknown object {name!r}{_suggest(str(name), known)} "
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

    def skills(self, task: dict[str, Any], robots: dict[str, _Robot]) -> list[_PickSkill]:
        path = (*self.path, "skills")
        if "skills" not in task:
            raise self.error(path, "required key is missing")
        picks: list[_PickSkill] = []
        skipped: dict[str, int] = {}
        for stage, stage_block in enumerate(self.sequence(task["skills"], path, "skills")):
            spath = (*path, stage)
            stage_block = self.mapping(stage_block, spath, "{robot name: [phases]}")
            for robot_name, phases in stage_block.items():
                rpath = (*spath, robot_name)
                if robot_name not in robots:
                    raise self.error(
                        rpath,
                        f"skills for unknown robot {robot_name!r}"
                        f"{_suggest(str(robot_name), robots)} (robots: {list(robots)})",
                    )
                robot = robots[robot_name]
                for phase, arms in enumerate(self.sequence(phases, rpath, "phases")):
                    ppath = (*rpath, phase)
                    arms = self.mapping(arms, ppath, "{left|right: [skills]}")
                    for arm, skill_list in arms.items():
                        apath = (*ppath, arm)
                        if arm not in ROBOT_ARMS[robot.harness]:
                            raise self.error(
                                apath,
                                f"{robot.harness} has no arm {arm!r} "
                                f"(arms: {', '.join(ROBOT_ARMS[robot.harness])})",
                            )
                        for k, skill in enumerate(self.sequence(skill_list, apath, "skills")):
                            kpath = (*apath, k)
                            skill = self.mapping(skill, kpath, "a skill")
                            name = skill.get("name")
                            if name == "pick":
                                picks.append(_PickSkill(skill, kpath, robot, arm, stage, phase, k))
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
        for name, count in skipped.items():
            log.warning(
                "%s: skipping %d %r skill(s); pick-harness runs pick skills only",
                self.where.file,
                count,
                name,
            )
        return picks

    # -- the harness task -------------------------------------------------------------------------

    def task_config(
        self,
        task: dict[str, Any],
        pick: _PickSkill,
        objects: dict[str, _Object],
        regions: dict[str, tuple[dict[str, Any], KeyPath]],
        pick_count: int,
        order: int,
    ) -> TaskConfig:
        origin: dict[KeyPath, KeyPath] = {(): self.path, ("pick",): pick.path}
        robot = pick.robot
        block = dict(pick.block)
        if "objects" not in block:
            raise self.error((*pick.path, "objects"), "a pick needs objects (the first is picked)")
        wanted = block["objects"]
        required = {str(n) for n in wanted} if isinstance(wanted, list) else set()
        robot_ignore = robot.config.get("ignore_substring")
        if robot_ignore is not None:
            own = block.get("ignore_substring") or []
            if isinstance(robot_ignore, list) and isinstance(own, list):
                block["ignore_substring"] = [
                    *robot_ignore,
                    *(s for s in own if s not in robot_ignore),
                ]
                origin[("pick", "ignore_substring")] = (*robot.path, "ignore_substring")

        target = str(wanted[0]) if isinstance(wanted, list) and wanted else None
        object_configs: list[dict[str, Any]] = []
        for obj in objects.values():
            config = self.object_config(obj, obj.name in required, regions, origin, object_configs)
            if config is not None and obj.name == target and self.check_grasps:
                self.check_grasp_file(obj, Path(config["mesh"]), block, pick.path)
            if config is not None:
                object_configs.append(config)

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
        if max_steps is not None:
            data["max_episode_length"] = max_steps
        else:
            self.note(f"{self.key((*self.path, 'data'))}: no max_episode_length; using 500")
        try:
            return TaskConfig.model_validate(data)
        except ValidationError as exc:
            raise self.translate(exc, origin) from None

    def object_config(
        self,
        obj: _Object,
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
        if obj.config.get("target_class", "RigidObject") != "RigidObject":
            self.note(
                f"{self.key((*obj.path, 'target_class'))}: "
                f"{obj.config.get('target_class')} simulated as a free rigid body"
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
        self, obj: _Object, mesh: Path, block: dict[str, Any], pick_path: KeyPath
    ) -> None:
        """The picked object's grasp file must exist: the pick's ``npy_name`` next to its asset
        (the reference's rule; the harness also takes ``<mesh>_grasps.npy`` or ``grasps.npy``
        for the default name). Checked here so a missing one is one located line up front, not
        an ``error`` row per episode."""
        from harness.errors import InputFileError
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


# --------------------------------------------------------------------------------------------
# Entry point


def load_interndata_tasks(
    path: str | Path,
    asset_root: Path | None = None,
    objects: dict[str, str] | None = None,
    check_assets: bool = True,
    check_grasps: bool = False,
) -> list[InternDataPick]:
    """Every ``pick`` skill of an InternDataEngine task file as a harness task, in run order.

    ``asset_root`` is the folder the objects' ``path`` values are relative to (default: the
    file's own ``asset_root``, relative to the current directory as in the reference).
    ``objects`` substitutes assets by object name: ``{name: PATH}`` or ``{name: PATH@SCALE}``; a
    substitute is used at scale 1 unless it gives one. ``check_assets`` makes a missing asset of a
    picked object an error (``harness validate`` turns it off); ``check_grasps`` (with
    ``check_assets``) also requires each pick's grasp file next to its object's asset, so that a
    run fails up front with one located line instead of an ``error`` row per episode
    (``harness run --interndata`` turns it on).
    """
    path = Path(path)
    substitutes = dict(objects or {})
    doc = read_yaml(path)
    where = _Located(doc, str(path))
    data = resolve_interpolations(doc, path)
    if not isinstance(data, dict) or not isinstance(data.get("tasks"), list) or not data["tasks"]:
        raise where.error((), "not an InternDataEngine task file (needs a non-empty 'tasks' list)")
    picks: list[InternDataPick] = []
    names: set[str] = set()
    for index, task in enumerate(data["tasks"]):
        mapper = _TaskMapper(
            where, task, index, asset_root, substitutes, check_assets, check_grasps
        )
        picks.extend(mapper.map(first_order=len(picks)))
        if isinstance(task, dict) and isinstance(task.get("objects"), list):
            names.update(
                o["name"]
                for o in task["objects"]
                if isinstance(o, dict) and isinstance(o.get("name"), str)
            )
    unknown = sorted(set(substitutes) - names)
    if unknown:
        raise ConfigError(
            f"--object {unknown[0]}: no object of that name in the file"
            f"{_suggest(unknown[0], sorted(names))} (objects: {sorted(names)})",
            file=path,
        )
    return picks


# ------------------------------------------------------------------------------------------
# What a run takes from a file (printed, and kept in the run directory)

NOTES_FILE = "skipped.txt"


def summary_lines(path: str | Path, picks: list[InternDataPick]) -> list[str]:
    """What the run takes from an InternData file: its picks, then the skills it skips."""
    lines = [f"InternDataEngine file {path}: {len(picks)} pick skill(s), each run as a task"]
    for pick in picks:
        objects = ", ".join(obj.name for obj in pick.task.objects)
        lines.append(
            f"  {pick.task.name}: {pick.key} -> {pick.robot} {pick.arm}, picks "
            f"{pick.task.target_object.name!r} (scene: {objects})"
        )
    skipped = picks[0].skipped_skills if picks else ()
    if skipped:
        lines.append(f"skipped {len(skipped)} skill(s) (pick-harness runs pick skills only):")
        lines.extend(f"  {skill.describe()}" for skill in skipped)
    return lines


def note_lines(path: str | Path, picks: list[InternDataPick]) -> list[str]:
    """The summary plus every note of the mapping (skipped skills, ignored keys), per task."""
    lines = summary_lines(path, picks)
    for pick in picks:
        lines += ["", f"notes for {pick.task.name} ({pick.key}):"]
        lines += [f"  {note}" for note in pick.skipped] or ["  none"]
    return lines


def write_notes(run_dir: Path, lines: list[str]) -> Path:
    """``RUN_DIR/skipped.txt`` with the given note lines."""
    out = run_dir / NOTES_FILE
    out.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return out
