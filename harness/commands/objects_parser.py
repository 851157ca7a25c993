"""``harness objects``' parser: list, show, build, library, tasks (kept out of cli.py, whose
size the structure test bounds)."""

from __future__ import annotations

from typing import Any

from harness.commands.flags import GRASP_COUNT, bounded_int

Subparsers = Any


def add_objects(sub: Subparsers, _handler_of: Any, _progress_every: Any = None) -> None:
    """``_handler_of(module, function)`` and ``_progress_every(parser)``: cli.py's."""
    """``harness objects list | show | build``"""
    objects = sub.add_parser("objects", help="list, show and build objects")
    osub = objects.add_subparsers(dest="objects_command", metavar="SUBCOMMAND", required=True)
    p = osub.add_parser("list", help="list the default objects")
    p.set_defaults(func=_handler_of("objects", "list_objects"))
    p = osub.add_parser("show", help="describe an object or mesh; optionally render it")
    p.add_argument("name", metavar="NAME_OR_MESH_PATH", help="a default object name or a mesh file")
    p.add_argument("--render", metavar="FILE.png", help="render the object to a PNG")
    p.set_defaults(func=_handler_of("objects", "show"))
    p = osub.add_parser("build", help="regenerate the default object set under tasks/objects")
    p.add_argument("--only", nargs="+", metavar="NAME", help="build only these objects")
    p.add_argument("--num", type=GRASP_COUNT, default=3000, help="grasps to generate per object")
    p.set_defaults(func=_handler_of("objects", "build"))
    p = osub.add_parser(
        "library",
        help="build an object library in the reference's layout (<group>/<name>/Aligned_obj.usd "
        "+ Aligned_grasp_sparse.npy) from the project's shapes at several sizes",
    )
    p.add_argument("out", metavar="DIR", help="the library folder to write")
    p.add_argument(
        "--count", type=bounded_int(1, 1000), help="the first N objects only (default: all 50)"
    )
    p.add_argument("--num", type=bounded_int(1, 100_000), default=3000, help="grasps per object")
    p.set_defaults(func=_handler_of("objects", "library"))
    p = osub.add_parser(
        "tasks",
        help="one InternDataEngine task file per object from one template (the reference's "
        "generate_pick_configs.py): only the object's path, category and task_dir change",
    )
    p.add_argument("template", metavar="TEMPLATE.yaml", help="a single-pick task file")
    p.add_argument("objects", nargs="+", metavar="OBJECTS_DIR", help="reference-layout folders")
    p.add_argument("--out", required=True, metavar="DIR", help="the folder of task files")
    p.add_argument(
        "--asset-root", metavar="DIR", help="write paths relative to this (default: absolute)"
    )
    p.set_defaults(func=_handler_of("objects", "tasks"))
