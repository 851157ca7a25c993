"""Template groups: the reference's per-object task files that share one filter template.

InternDataEngine writes one single-pick task file per object, all made from one template per
robot arm (``scripts/generate_pick_configs.py`` copies the banana config and swaps the object),
so inside ``pick_and_place/<robot>/single_pick/<arm>/`` the files are identical except for the
object (``path``, ``category``, ``task_dir``). The decision a data team makes is one filter
setting for such a folder. This module finds those groups among the files a tune is given: a
file's *body* is its resolved YAML without the object's keys (:data:`OBJECT_KEYS` on every
object entry, ``data.task_dir``); files with the same body form one group, whose template the tune
decides over every object (``harness.tuning.run``). Files that differ in more than the object
form groups of their own, and :func:`group_lines` says which keys differ.
"""

from __future__ import annotations

import glob
import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from harness.config import ConfigError

# The keys of an object entry that name the object (what the reference's generator swaps, plus
# what follows the asset: its dataset and scale; the reference's folders keep scale fixed).
OBJECT_KEYS = ("path", "category", "dataset", "scale")
DATA_OBJECT_KEYS = ("task_dir",)  # data.task_dir: single_pick/<category>


def expand_paths(paths: list[Path]) -> list[Path]:
    """Task and sweep files: a folder gives its ``*.yaml`` files (sorted), a path with ``*``,
    ``?`` or ``[`` that names no file is a glob; a glob or folder matching nothing is refused."""
    out: list[Path] = []
    for path in paths:
        if path.is_dir():
            found = sorted(p for p in path.iterdir() if p.suffix in (".yaml", ".yml"))
            if not found:
                raise ConfigError(f"folder {path}: no .yaml task files in it")
            out.extend(found)
        elif not path.exists() and any(c in str(path) for c in "*?["):
            found = sorted(Path(p) for p in glob.glob(str(path)) if Path(p).is_file())
            if not found:
                raise ConfigError(f"{path}: the pattern matches no file")
            out.extend(found)
        else:
            out.append(path)
    return list(dict.fromkeys(out))


def body_of(data: Any) -> Any:
    """The resolved task file without the object's keys (see the module)."""
    if not isinstance(data, dict) or not isinstance(data.get("tasks"), list):
        return data
    body = json.loads(json.dumps(data, default=str))
    for task in body["tasks"]:
        if not isinstance(task, dict):
            continue
        for obj in task.get("objects") or []:
            if isinstance(obj, dict):
                for key in OBJECT_KEYS:
                    obj.pop(key, None)
        if isinstance(task.get("data"), dict):
            for key in DATA_OBJECT_KEYS:
                task["data"].pop(key, None)
    return body


def _flat(value: Any, prefix: str = "") -> dict[str, str]:
    if isinstance(value, dict):
        out: dict[str, str] = {}
        for key, sub in value.items():
            out.update(_flat(sub, f"{prefix}.{key}" if prefix else str(key)))
        return out
    if isinstance(value, list) and any(isinstance(v, dict | list) for v in value):
        out = {}
        for i, sub in enumerate(value):
            out.update(_flat(sub, f"{prefix}[{i}]"))
        return out
    return {prefix: json.dumps(value, sort_keys=True, default=str)}


@dataclass(frozen=True)
class TemplateGroup:
    """Files whose bodies are equal: one template over their objects."""

    name: str
    files: tuple[Path, ...]
    body: str  # the body's digest
    differs: tuple[str, ...] = ()  # keys whose values differ from the largest group's


def group_files(bodies: dict[Path, Any]) -> list[TemplateGroup]:
    """Group files by body (largest group first, then by first file); each group is named by its
    files' folder (a suffix ``#2``, ``#3`` when one folder holds several groups)."""
    by_digest: dict[str, list[Path]] = {}
    flat: dict[str, dict[str, str]] = {}
    for path, body in bodies.items():
        text = json.dumps(body, sort_keys=True, default=str)
        digest = hashlib.sha256(text.encode()).hexdigest()[:12]
        by_digest.setdefault(digest, []).append(path)
        flat.setdefault(digest, _flat(body))
    ordered = sorted(by_digest.items(), key=lambda kv: (-len(kv[1]), str(kv[1][0])))
    largest = flat[ordered[0][0]] if ordered else {}
    groups: list[TemplateGroup] = []
    seen: dict[str, int] = {}
    for digest, files in ordered:
        folder = files[0].parent.name or "files"
        seen[folder] = seen.get(folder, 0) + 1
        name = folder if seen[folder] == 1 else f"{folder}#{seen[folder]}"
        mine = flat[digest]
        differs = sorted(k for k in set(mine) | set(largest) if mine.get(k) != largest.get(k))
        groups.append(TemplateGroup(name, tuple(files), digest, tuple(differs)))
    return groups


def group_lines(groups: list[TemplateGroup]) -> list[str]:
    """What the grouping found, a line per group: its files and, past the first, the keys that
    set it apart (the first few)."""
    lines = []
    for i, group in enumerate(groups):
        line = f"template group {group.name}: {len(group.files)} file(s)"
        if len(group.files) == 1:
            line += f" ({group.files[0].name}: tuned as one object)"
        if i and group.differs:
            shown = ", ".join(group.differs[:4])
            more = f" and {len(group.differs) - 4} more" if len(group.differs) > 4 else ""
            line += f"; differs from {groups[0].name} in {shown}{more}"
        lines.append(line)
    return lines
