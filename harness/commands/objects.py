"""``harness objects list | show | build``: the default object set and any mesh.

``show --render FILE.png`` draws three offscreen MuJoCo views side by side: the mesh, its convex
collision pieces, and a sample of its grasps as gripper boxes (coloured by score, green = 0.1),
drawn by ``harness.viz.object_render``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from harness.commands.console import say
from harness.commands.graspgen import summary
from harness.errors import HarnessError, InputFileError
from harness.files import safe_file_name
from harness.grasps.grasp_set import read_grasp_array
from harness.objects.assets import (
    ObjectAsset,
    default_objects_dir,
    list_default_objects,
    load_object_info,
    resolve_mesh,
)
from harness.objects.graspgen import generate_grasps
from harness.objects.meshes import load_mesh
from harness.objects.shapes import (
    DEFAULT_OBJECTS,
    FIT_FRACTION,
    default_object,
    obj_text,
)
from harness.robots import available_robots
from harness.robots.facts import max_jaw_opening
from harness.viz.formats import IMAGE_SUFFIXES, check_suffix
from harness.viz.object_render import render_object
from harness.writes import write_file

# --------------------------------------------------------------------------------------------
# list / show


def list_objects(args: argparse.Namespace) -> int:
    names = list_default_objects()
    if not names:
        say(f"no default objects under {default_objects_dir()} (run `harness objects build`)")
        return 0
    say(f"{'name':<8} {'category':<8} {'size (cm)':<18} {'verts':>6} {'grasps':>6}  fits")
    for name in names:
        info = load_object_info(name)
        size = "x".join(f"{100 * e:.1f}" for e in info.get("extents_m", []))
        fits = ", ".join(info.get("fits", [])) or "-"
        say(
            f"{name:<8} {info.get('category', ''):<8} {size:<18} {info.get('vertices', 0):>6} "
            f"{info.get('grasp_count', 0):>6}  {fits}"
        )
    return 0


def _load_for_show(name: str) -> tuple[ObjectAsset, dict[str, Any] | None]:
    path = resolve_mesh(name, Path.cwd())
    info = None
    if path.resolve().parent == (default_objects_dir() / name).resolve():
        info = load_object_info(name)
    mass = float(info["mass"]) if info else 0.1
    friction = float(info["friction"]) if info else 1.0
    return ObjectAsset.load(path, mass=mass, friction=friction), info


def describe(asset: ObjectAsset, info: dict[str, Any] | None) -> list[str]:
    """Human-readable lines about an asset."""
    lo, hi = asset.bounds
    mesh = asset.mesh
    piece_vertices = sum(len(v) for v, _ in asset.collision_pieces)
    lines = [
        f"mesh        {asset.path}",
        f"vertices    {len(asset.vertices)}  faces {len(asset.faces)}  "
        f"watertight {mesh.is_watertight}",
        f"bounds (m)  min {np.round(lo, 4).tolist()}  max {np.round(hi, 4).tolist()}",
        f"extents (m) {np.round(asset.extents, 4).tolist()}",
        f"mass        {asset.mass:g} kg  friction {asset.friction:g}  "
        f"COM {np.round(asset.center_of_mass, 4).tolist()}",
        f"inertia     diag {np.round(np.diag(asset.inertia), 8).tolist()} kg m^2",
        f"collision   {len(asset.collision_pieces)} convex piece(s), {piece_vertices} vertices "
        f"(source: {asset.collision_source})",
    ]
    if asset.grasp_path is None:
        lines.append("grasps      none found (harness grasps generate MESH --out FILE)")
    else:
        grasps = read_grasp_array(asset.grasp_path)
        shape = "x".join(str(s) for s in grasps.shape)
        lines.append(f"grasps      {asset.grasp_path} ({shape})")
        if grasps.ndim == 2 and grasps.shape[1] == 17:
            lines.append(f"            {summary(grasps)}")
    if info:
        lines.append(f"category    {info.get('category')}: {info.get('description', '')}")
        lines.append(f"fits        {', '.join(info.get('fits', [])) or 'no gripper'}")
    return lines


def show(args: argparse.Namespace) -> int:
    if args.render:
        check_suffix(args.render, IMAGE_SUFFIXES, "--render")
    asset, info = _load_for_show(args.name)
    say("\n".join(describe(asset, info)))
    if args.render:
        out = render_object(asset, Path(args.render))
        say(f"wrote {out}")
    return 0


# --------------------------------------------------------------------------------------------
# build


def gripper_fit(widths: np.ndarray) -> dict[str, dict[str, float]]:
    """Per gripper: its maximum opening and the fraction of grasp widths within it.

    The openings are each bundled robot's jaw opening (``open_width`` in robots/<name>/robot.yaml).
    """
    openings = {name: max_jaw_opening(name) for name in available_robots()}
    return {
        name: {
            "max_width": max_width,
            "fraction": round(float(np.mean(widths <= max_width)) if len(widths) else 0.0, 3),
        }
        for name, max_width in openings.items()
    }


def build_object(name: str, out_root: Path, n: int = 3000, seed: int = 0) -> dict[str, Any]:
    """Write ``out_root/<name>/{<name>.obj, grasps.npy, object.yaml}`` for one default object.

    The grasps are generated from the mesh as re-read from the written OBJ, so regenerating them
    from the file with ``harness grasps generate`` and the same seed gives the same bytes.
    """
    spec = default_object(name)
    folder = out_root / safe_file_name(name)
    folder.mkdir(parents=True, exist_ok=True)
    mesh_file = folder / safe_file_name(name, ".obj")
    write_file(mesh_file, obj_text(spec.build()))
    mesh = load_mesh(mesh_file)
    result = generate_grasps(mesh, n=n, seed=seed)
    result.save(folder / "grasps.npy")
    grasps = result.grasps
    scores, counts = np.unique(np.round(grasps[:, 0].astype(float), 1), return_counts=True)
    fit = gripper_fit(grasps[:, 1])
    info: dict[str, Any] = {
        "name": name,
        "category": spec.category,
        "description": spec.description,
        "mesh": mesh_file.name,
        "grasps": "grasps.npy",
        "mass": spec.mass,
        "friction": spec.friction,
        "orientations": [[float(a) for a in o] for o in spec.orientations],
        "extents_m": [round(float(e), 4) for e in mesh.extents],
        "vertices": len(mesh.vertices),
        "faces": len(mesh.faces),
        "grasp_count": len(grasps),
        "grasp_seed": seed,
        "score_counts": {f"{s:.1f}": int(c) for s, c in zip(scores, counts, strict=True)},
        "width_range_m": [round(float(grasps[:, 1].min()), 4), round(float(grasps[:, 1].max()), 4)],
        "grippers": fit,
        "fits": [g for g, v in fit.items() if v["fraction"] >= FIT_FRACTION],
    }
    header = (
        "# Generated by `harness objects build` (harness/objects/shapes.py); do not edit by hand.\n"
        "# grippers: fraction of grasp rows whose width is within each gripper's opening\n"
        "# (split_aloha: the reference piper100 jaw 0.10 m; the SDK variant sdk070 opens 0.07 m).\n"
    )
    text = header + yaml.safe_dump(info, sort_keys=False, default_flow_style=None, width=100)
    write_file(folder / "object.yaml", text)
    return info


def build(args: argparse.Namespace) -> int:
    known = [spec.name for spec in DEFAULT_OBJECTS]
    names = args.only or known
    unknown = [name for name in names if name not in known]
    if unknown:
        raise HarnessError(f"unknown default object(s) {unknown}; known: {known}")
    if args.num <= 0:
        raise HarnessError(f"--num must be positive, got {args.num}")
    root = default_objects_dir()
    for name in names:
        start = time.perf_counter()
        info = build_object(name, root, n=args.num)
        try:  # validates the files and warms the collision cache
            asset = ObjectAsset.load(root / name / info["mesh"], mass=info["mass"])
        except InputFileError as exc:
            raise HarnessError(f"built object {name!r} does not load: {exc}") from exc
        say(
            f"{name:<8} {info['vertices']:>5} vertices, {info['grasp_count']} grasps "
            f"{info['score_counts']}, {len(asset.collision_pieces)} collision piece(s), "
            f"fits {info['fits']} ({time.perf_counter() - start:.1f} s)"
        )
    return 0


def library(args: argparse.Namespace) -> int:
    """``harness objects library DIR``: the reference-layout object library."""
    from harness.objects.library import build_library

    out = Path(args.out)
    written = build_library(out, args.count, args.num, say=lambda line: say(f"  {line}"))
    say(f"{len(written)} objects in {out} (harness objects tasks TEMPLATE {out} --out DIR)")
    return 0


def tasks(args: argparse.Namespace) -> int:
    """``harness objects tasks TEMPLATE OBJECTS... --out DIR``: per-object task files."""
    from harness.interndata.generate import generate_task_files

    root = Path(args.asset_root) if args.asset_root else None
    written = generate_task_files(
        Path(args.template), [Path(o) for o in args.objects], Path(args.out), root
    )
    say(f"{len(written)} task files in {args.out} (harness tune {args.out} ...)")
    return 0
