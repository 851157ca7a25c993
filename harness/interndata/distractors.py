"""A task's ``distractors`` block -> extra rigid objects on the table.

The reference (workflows/simbox/core/tasks/banana.py, ``_create_distractor_cfg``, lines
646-700) lists every ``<asset_root>/<path>/<category>/<name>/*.usd``, drops the categories of the
task's own objects (the asset path's grandparent folder), ``exclude_categories`` and any category
containing one of ``exclude_keywords`` (case-insensitive), draws a count uniformly from
``min_num`` to ``min(max_num, available)`` and that many assets at random, and loads each as a
``RigidObject`` (``target_class`` default) named ``distractors/<name>`` with the block's
``scale``, turned by its category's orientation and a random yaw, and placed on the table within
``pos_range`` (xy) at least ``min_object_distance`` from the other objects
(core/utils/visual_distractor.py). They are rigid bodies and, not matching the controllers'
ignore list, obstacles of its planning world.

Here they become ordinary objects of the scene (free bodies, so planning obstacles too), with
one approximation: the set is drawn once per task (seeded by the file name), at the middle of the
count range, not again each episode, because the harness builds one MuJoCo scene per task.
Placement is per episode, at ``min_object_distance`` from every object placed before it.
"""

from __future__ import annotations

import random
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

from harness.interndata.orientations import suggested_orientations

NAME_PREFIX = "distractors_"


def available_assets(folder: Path, own_categories: set[str], block: dict[str, Any]) -> list[Path]:
    """The distractor assets the reference would choose from, sorted (its glob, filtered)."""
    excluded = {str(c) for c in block.get("exclude_categories") or []}
    keywords = [str(k).lower() for k in block.get("exclude_keywords") or []]
    out = []
    for path in sorted(folder.glob("*/*/*.usd")):
        category = path.parts[-3]
        if category in own_categories or category in excluded:
            continue
        if any(keyword in category.lower() for keyword in keywords):
            continue
        out.append(path)
    return out


def distractor_objects(
    block: dict[str, Any],
    asset_base: Path,
    own_categories: set[str],
    seed_text: str,
    note: Callable[[str], None],
    where: str,
) -> list[dict[str, Any]]:
    """Object configs (``TaskConfig.objects`` entries) for a ``distractors`` block."""
    folder = asset_base / str(block.get("path", ""))
    if not folder.is_dir():
        note(
            f"{where}: distractor folder not found ({folder}); the scene goes without the "
            "reference's distractors (give --asset-root with its asset tree to include them)"
        )
        return []
    assets = available_assets(folder, own_categories, block)
    low = int(block.get("min_num", 0))
    high = min(int(block.get("max_num", low)), len(assets))
    if not assets or high <= 0:
        note(f"{where}: no distractor asset left after the category filters in {folder}")
        return []
    count = max(0, min(high, (low + high) // 2))
    rng = random.Random(zlib.crc32(seed_text.encode()))
    chosen = rng.sample(assets, count)
    note(
        f"{where}: {count} distractors drawn once for this task (the reference draws "
        f"{low}-{high} again each episode): {', '.join(p.parts[-2] for p in chosen)}"
    )
    (x0, y0), (x1, y1) = [tuple(float(v) for v in row[:2]) for row in block["pos_range"]]
    scale = block.get("scale", [1.0, 1.0, 1.0])
    target_class = block.get("target_class", "RigidObject")
    out = []
    names: set[str] = set()
    for path in chosen:
        name = NAME_PREFIX + path.parts[-2].replace("-", "_")
        if name in names:  # the same asset folder name in two categories
            name = f"{name}_{len(names)}"
        names.add(name)
        config: dict[str, Any] = {
            "name": name,
            "mesh": str(path),
            "scale": scale,
            "orientations": suggested_orientations(path.parts[-3]),
            "category": path.parts[-3],
            "placement": {
                "pos_range": [[x0, y0, 0.0], [x1, y1, 0.0]],
                "yaw_range": [-180.0, 180.0],
            },
            "min_distance": float(block.get("min_object_distance", 0.0)),
        }
        if target_class == "GeometryObject":
            config["fixed"] = True
        out.append(config)
    return out
