"""Writing ``robots/<name>/<name>.urdf`` and ``collisions.json`` from each folder's ``build.py``.

The robot list is the registry's (every ``robots/<name>/`` with a robot.yaml); a folder with a
``build.py`` is generated, one without (a robot whose URDF comes from elsewhere) is left alone.
``python robots/build_urdfs.py [name ...] [--no-collisions]`` runs :func:`main`.
"""

from __future__ import annotations

import importlib.util
import json
import sys
from types import ModuleType

from harness.config.robot_registry import ROBOTS_DIR, available_robots
from harness.files import safe_file_name
from harness.robots.generator.collisions import collision_pairs
from harness.robots.generator.shapes import Robot
from harness.robots.generator.urdf_text import urdf_text


def generated_robots() -> list[str]:
    """The bundled robots whose folder holds a ``build.py``."""
    return [name for name in available_robots() if (ROBOTS_DIR / name / "build.py").is_file()]


def build_module(name: str) -> ModuleType:
    """``robots/<name>/build.py`` (data, not a package module) imported by path."""
    path = ROBOTS_DIR / name / "build.py"
    module_name = f"harness_robot_build_{name}"
    if module_name in sys.modules:
        return sys.modules[module_name]
    spec = importlib.util.spec_from_file_location(module_name, path)
    if spec is None or spec.loader is None:
        raise ImportError(f"{path}: cannot be imported")
    module = importlib.util.module_from_spec(spec)
    sys.modules[module_name] = module
    spec.loader.exec_module(module)
    return module


def build_robot(name: str) -> Robot:
    """The robot ``robots/<name>/build.py`` describes."""
    robot = build_module(name).build()
    if not isinstance(robot, Robot) or robot.name != name:
        raise TypeError(f"robots/{name}/build.py: build() must return a Robot named {name!r}")
    return robot


def write_robot(name: str, collisions: bool = True) -> None:
    """Write the URDF (and, unless told not to, collisions.json) of one robot folder."""
    robot = build_robot(name)
    folder = ROBOTS_DIR / name
    urdf = folder / safe_file_name(name, ".urdf")  # a robot folder name is already a safe name
    urdf.write_text(urdf_text(robot))
    print(f"{name}: {len(robot.links)} links, {len(robot.joints)} joints")
    if not collisions:
        return
    pairs = collision_pairs(robot, urdf)
    (folder / "collisions.json").write_text(json.dumps(pairs, indent=1) + "\n")
    print(f"{name}: {len(pairs)} self-collision pairs")


def main(argv: list[str] | None = None) -> None:
    """Generate the named robots (all with a build.py when none is named)."""
    args = sys.argv[1:] if argv is None else argv
    names = [a for a in args if not a.startswith("--")] or generated_robots()
    for name in names:
        write_robot(name, collisions="--no-collisions" not in args)
