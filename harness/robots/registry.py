"""Finding robots: the bundled robots folder, their names, and resolving a name or path.

``robots/`` at the repository root is data (robot.yaml + URDF per robot); this module maps a
robot name (``fr3``), a robot.yaml path or its folder to the robot.yaml file.
"""

from __future__ import annotations

from pathlib import Path

from harness.errors import HarnessError
from harness.files import MAX_CONFIG_BYTES, read_capped

ROBOTS_DIR = Path(__file__).resolve().parents[2] / "robots"
"""Folder of the bundled robots: ``robots/<name>/robot.yaml``."""


def available_robots() -> list[str]:
    """Names of the bundled robots (folders of ``robots/`` holding a robot.yaml)."""
    if not ROBOTS_DIR.is_dir():
        return []
    return sorted(p.parent.name for p in ROBOTS_DIR.glob("*/robot.yaml"))


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
    if bundled.is_file():
        return bundled
    raise HarnessError(
        f"unknown robot {text!r}; available robots: {', '.join(available_robots()) or 'none'}"
    )


def gripper_variant_names(name_or_path: str) -> list[str] | None:
    """The gripper variants of a robot.yaml (default first), or None if it cannot be read.

    Read without validating the file, so task validation can check a variant name without
    loading the robot (robot.yaml problems are reported when the robot is loaded).
    """
    import yaml

    try:
        text = read_capped(resolve_robot_yaml(name_or_path), MAX_CONFIG_BYTES).decode("utf-8")
        data = yaml.safe_load(text)
    except (HarnessError, OSError, ValueError, yaml.YAMLError):
        return None
    if not isinstance(data, dict):
        return None
    variants = data.get("gripper_variants") or {}
    return [str(data.get("gripper_variant", "default")), *map(str, variants)]
