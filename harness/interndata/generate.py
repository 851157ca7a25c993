"""Per-object task files from one template, as the reference's generator makes them.

InternDataEngine's ``scripts/generate_pick_configs.py`` copies one single-pick config (the
banana's) once per object and swaps the object: its asset ``path``, its ``category`` and the
data's ``task_dir``; nothing else changes, so every file of a robot arm's ``single_pick`` folder
holds the same filters. ``harness objects tasks TEMPLATE OBJECTS... --out DIR`` does the same
for a folder of objects in the reference's layout (``<group>/<name>/Aligned_obj.usd`` with
``Aligned_grasp_sparse.npy`` beside it; ``harness objects library`` builds one), editing only
those three lines of the template (:mod:`harness.config.line_edit`), so the files group into one
template (:mod:`harness.tuning.templates`) and ``harness tune DIR`` decides that template.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from harness.config import ConfigError, read_yaml
from harness.config.line_edit import set_values
from harness.files import MAX_CONFIG_BYTES, read_capped, safe_file_name
from harness.objects.library import GRASP_NAME, MESH_NAME
from harness.writes import write_file


@dataclass(frozen=True)
class FoundObject:
    """An object of a reference-layout folder: its group, name and asset."""

    group: str
    name: str
    mesh: Path


def find_objects(roots: list[Path]) -> list[FoundObject]:
    """Every ``<group>/<name>/Aligned_obj.usd`` with a grasp file beside it under ``roots``."""
    found: list[FoundObject] = []
    for root in roots:
        if not root.is_dir():
            raise ConfigError(f"objects folder not found: {root}")
        for mesh in sorted(root.glob(f"*/*/{MESH_NAME}")):
            if (mesh.parent / GRASP_NAME).is_file():
                found.append(FoundObject(mesh.parent.parent.name, mesh.parent.name, mesh))
    if not found:
        raise ConfigError(
            f"no objects in {', '.join(map(str, roots))} (expected <group>/<name>/{MESH_NAME} "
            f"with {GRASP_NAME} beside it: harness objects library DIR builds such a folder)"
        )
    return found


def picked_object(data: object, where: Path) -> tuple[int, int]:
    """(task index, object index) of the object the file's pick skill picks."""
    tasks = data.get("tasks") if isinstance(data, dict) else None
    if not isinstance(tasks, list) or not tasks or not isinstance(tasks[0], dict):
        raise ConfigError("not an InternDataEngine task file", file=where)
    names = [o.get("name") for o in tasks[0].get("objects") or [] if isinstance(o, dict)]
    picked: list[str] = []

    def walk(node: object) -> None:
        if isinstance(node, dict):
            if node.get("name") == "pick" and isinstance(node.get("objects"), list):
                picked.extend(str(n) for n in node["objects"])
            for value in node.values():
                walk(value)
        elif isinstance(node, list):
            for value in node:
                walk(value)

    walk(tasks[0].get("skills"))
    distinct = list(dict.fromkeys(p for p in picked if p in names))
    if len(distinct) != 1:
        raise ConfigError(
            "a template for per-object files picks one object; this one picks "
            f"{distinct or 'none'}",
            file=where,
            key="tasks[0].skills",
        )
    return 0, names.index(distinct[0])


def generate_task_files(
    template: Path, roots: list[Path], out: Path, asset_root: Path | None = None
) -> list[Path]:
    """One copy of ``template`` per object of ``roots`` in ``out`` (``<group>-<name>.yaml``),
    with only the picked object's ``path`` and ``category`` and the data's ``task_dir``
    changed. ``path`` is relative to ``asset_root`` when the object lies under it (run the
    files with ``--asset-root``), else absolute."""
    text = read_capped(template, MAX_CONFIG_BYTES).decode("utf-8")
    data = read_yaml(template).data
    task_index, object_index = picked_object(data, template)
    task_dir = str(((data["tasks"][task_index].get("data") or {}).get("task_dir")) or "")
    written = []
    for obj in find_objects(roots):
        mesh = obj.mesh.resolve()
        if asset_root is not None and mesh.is_relative_to(asset_root.resolve()):
            path = str(mesh.relative_to(asset_root.resolve()))
        else:
            path = str(mesh)
        edits: dict[tuple[str | int, ...], dict[str, object]] = {
            ("tasks", task_index, "objects", object_index): {"path": path, "category": obj.name}
        }
        if task_dir:
            head = task_dir.rsplit("/", 1)[0] if "/" in task_dir else ""
            edits[("tasks", task_index, "data")] = {
                "task_dir": f"{head}/{obj.name}" if head else obj.name
            }
        copy = set_values(text, edits, str(template))
        name = safe_file_name(f"{obj.group}-{obj.name}", ".yaml")
        written.append(write_file(out / name, copy, root=out))
    return written
