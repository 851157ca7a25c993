"""The robot registry: the bundled robots folder, their names, and resolving a name or path.

``robots/`` at the repository root is data (a folder per robot: robot.yaml, build.py, URDF);
this module maps a robot name (``fr3``), a robot.yaml path or its folder to the robot.yaml file.
:func:`available_robots` is THE robot list: tests, benchmarks and tools iterate it instead of
naming robots. It lives in ``config`` (not ``robots``) because task validation resolves robot
names and gripper variants, and ``robots`` builds on ``config``: one direction between the two.
"""

from __future__ import annotations

from pathlib import Path

from harness.errors import HarnessError
from harness.files import MAX_CONFIG_BYTES, read_capped

ROBOTS_DIR = Path(__file__).resolve().parents[2] / "robots"
"""Folder of the bundled robots: ``robots/<name>/robot.yaml``."""


def available_robots() -> list[str]:
    """Names of the bundled robots (folders of ``robots/`` holding a robot.yaml), sorted; a
    folder whose name starts with ``_`` (``robots/_template/``) is not a robot."""
    if not ROBOTS_DIR.is_dir():
        return []
    folders = (p.parent.name for p in ROBOTS_DIR.glob("*/robot.yaml"))
    return sorted(name for name in folders if not name.startswith("_"))


def resolve_robot_yaml(name_or_path: str | Path) -> Path:
    """A bundled robot name, a robot.yaml path or its folder -> the robot.yaml path."""
    text = str(name_or_path)
    candidate = Path(text).expanduser()
    looks_like_path = isinstance(name_or_path, Path) or "/" in text or text.endswith(".yaml")
    if candidate.is_dir() and (candidate / "robot.yaml").is_file():
        return (candidate / "robot.yaml").resolve()
    if candidate.is_file():
        return candidate.resolve()
    if looks_like_path:
        raise HarnessError(f"{text}: robot file not found (expected a robot.yaml or its folder)")
    bundled = ROBOTS_DIR / text / "robot.yaml"
    if bundled.is_file() and not text.startswith("_"):
        return bundled
    raise HarnessError(
        f"unknown robot {text!r}; available robots: {', '.join(available_robots()) or 'none'}"
    )


def _raw_robot_yaml(name_or_path: str) -> dict | None:
    """A robot.yaml as a plain dict, not validated; None if it cannot be read (robot.yaml
    problems are reported when the robot is loaded)."""
    import yaml

    try:
        text = read_capped(resolve_robot_yaml(name_or_path), MAX_CONFIG_BYTES).decode("utf-8")
        data = yaml.safe_load(text)
    except (HarnessError, OSError, ValueError, yaml.YAMLError):
        return None
    return data if isinstance(data, dict) else None


def placement_defaults(name_or_path: str, arm: str) -> dict[str, dict | None]:
    """The placements a task inherits from robot.yaml when it sets none: ``robot_placement``
    (robot.yaml ``placement``) and ``object`` (the arm's ``object_region``); None where the
    file does not say. A ``--set robot_placement.pos_range=...`` starts from these, so the
    keys it does not name keep their robot.yaml values (issue 33: the yaw range fell back to
    [-180, 180] and the robot faced a random way)."""
    data = _raw_robot_yaml(name_or_path) or {}
    arms = data.get("arms")
    arm_data = arms.get(arm) if isinstance(arms, dict) else None
    region = arm_data.get("object_region") if isinstance(arm_data, dict) else None
    placement = data.get("placement")
    return {
        "robot_placement": placement if isinstance(placement, dict) else None,
        "object": region if isinstance(region, dict) else None,
    }


def gripper_variant_names(name_or_path: str) -> list[str] | None:
    """The gripper variants of a robot.yaml (default first), or None if it cannot be read.

    Read without validating the file, so task validation can check a variant name without
    loading the robot (robot.yaml problems are reported when the robot is loaded).
    """
    data = _raw_robot_yaml(name_or_path)
    if data is None:
        return None
    variants = data.get("gripper_variants") or {}
    return [str(data.get("gripper_variant", "default")), *map(str, variants)]


TASKS_DIR = ROBOTS_DIR.parent / "tasks" / "pick"
"""Folder of the canonical pick tasks: ``<robot>.yaml`` or ``<robot>_<arm>.yaml``."""


def canonical_task_files(name: str) -> list[Path]:
    """The canonical pick task files of a bundled robot, sorted: ``tasks/pick/<name>.yaml``
    and ``tasks/pick/<name>_left.yaml`` / ``<name>_right.yaml`` (one per arm it is tested with)."""
    stems = {name, f"{name}_left", f"{name}_right"}
    return sorted(p for p in TASKS_DIR.glob("*.yaml") if p.stem in stems)
