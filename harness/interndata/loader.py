"""The entry point: every ``pick`` skill of an InternDataEngine task file as a harness task."""

from __future__ import annotations

from pathlib import Path

from harness.config.errors import ConfigError
from harness.config.loading import read_yaml
from harness.config.messages import suggest
from harness.interndata.errors import Located
from harness.interndata.interpolation import resolve_interpolations
from harness.interndata.mapper import TaskMapper
from harness.interndata.result import InternDataPick


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
    where = Located(doc, str(path))
    data = resolve_interpolations(doc, path)
    if not isinstance(data, dict) or not isinstance(data.get("tasks"), list) or not data["tasks"]:
        raise where.error((), "not an InternDataEngine task file (needs a non-empty 'tasks' list)")
    picks: list[InternDataPick] = []
    names: set[str] = set()
    for index, task in enumerate(data["tasks"]):
        mapper = TaskMapper(where, task, index, asset_root, substitutes, check_assets, check_grasps)
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
            f"{suggest(unknown[0], sorted(names))} (objects: {sorted(names)})",
            file=path,
        )
    return picks
