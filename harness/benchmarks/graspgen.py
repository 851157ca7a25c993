"""Benchmark section ``graspgen``: annotating a mesh and loading an object asset, on one core.

- 3000 grasps for a 5,000-vertex mesh (target under 30 s): the procedural banana at a resolution
  of 5,002 vertices, and the InternDataEngine example bottle (4,843 vertices) when the shared
  data is present. The process is pinned to one CPU while these run.
- ``ObjectAsset.load`` with the convex decomposition already in the disk cache (what every
  worker pays once per object), next to the one-time CoACD decomposition of the same mesh.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

from harness.benchmarks.framework import Figure, figure, time_call
from harness.benchmarks.machine import one_core
from harness.objects import shapes
from harness.objects.assets import ObjectAsset
from harness.objects.graspgen import generate_grasps
from harness.objects.meshes import load_mesh

SECTION = "graspgen"
EXAMPLE_BOTTLE = (
    Path(__file__).resolve().parents[2].parent
    / "shared/datasets/interndata-examples/objects/recyclable_garbage/bottle_0/Aligned_obj.usd"
)


def _generation_figures(quick: bool) -> list[Figure]:
    meshes = [("banana", shapes.banana(rings=100, sections=50))]
    if EXAMPLE_BOTTLE.is_file():
        meshes.append(("example bottle_0", load_mesh(EXAMPLE_BOTTLE)))
    reps = 1 if quick else 3
    figures = []
    with one_core() as note:
        for label, mesh in meshes:
            stats: dict = {}

            def run_once(mesh=mesh, stats=stats) -> None:
                stats.update(generate_grasps(mesh, n=3000, seed=0).stats)

            samples = time_call(run_once, reps, warmup=0)
            figures.append(
                figure(
                    SECTION,
                    f"3000 grasps, {label} ({len(mesh.vertices)} vertices)",
                    samples,
                    "s",
                    target=30.0,
                    notes=f"one core ({note}); {stats['accepted']} grasps from "
                    f"{stats['pairs_sampled']} sampled pairs, {stats['checked']} gripper checks",
                    extra={k: v for k, v in stats.items() if k != "seconds"},
                )
            )
    return figures


def _load_figures(quick: bool) -> list[Figure]:
    with tempfile.TemporaryDirectory() as tmp:
        previous = os.environ.get("PICK_HARNESS_CACHE")
        os.environ["PICK_HARNESS_CACHE"] = tmp
        try:
            mesh_path = Path(tmp) / "mug.obj"
            mesh_path.write_text(shapes.obj_text(shapes.mug()), encoding="utf-8")
            start = time.perf_counter()
            first = ObjectAsset.load(mesh_path)
            decompose = time.perf_counter() - start
            samples = time_call(lambda: ObjectAsset.load(mesh_path), 5 if quick else 20)
            second = ObjectAsset.load(mesh_path)
        finally:
            if previous is None:
                os.environ.pop("PICK_HARNESS_CACHE", None)
            else:
                os.environ["PICK_HARNESS_CACHE"] = previous
    assert first.collision_source == "coacd" and second.collision_source == "cache"
    pieces = len(first.collision_pieces)
    return [
        figure(
            SECTION,
            f"ObjectAsset.load, cached decomposition (mug, {len(first.vertices)} vertices)",
            samples,
            "ms",
            scale=1e3,
            notes=f"{pieces} convex pieces from the disk cache",
        ),
        figure(
            SECTION,
            "first load incl. CoACD decomposition (mug)",
            [decompose],
            "s",
            notes="paid once per mesh, scale and CoACD parameters on a machine",
        ),
    ]


def run(quick: bool) -> list[Figure]:
    return _generation_figures(quick) + _load_figures(quick)
