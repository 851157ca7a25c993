"""An object library in the reference's layout, built from the project's own shapes.

A template tune decides one filter setting for a folder of ~100 per-object task files; two shapes
say little about a hundred objects. The reference's objects are not public beyond the examples,
so ``harness objects library OUT`` builds a set of distinct objects from the procedural shapes
(:mod:`harness.objects.shapes`) at several sizes and proportions, each written as the reference
writes its assets (``OUT/<group>/<name>/Aligned_obj.usd`` + ``Aligned_grasp_sparse.npy``):

- the mesh under ``/World/Aligned`` in **millimetres**, as the reference's pre-train-pick assets
  are (their task files load them with ``scale: [0.001, 0.001, 0.001]``, e.g.
  tasks/folders/fr3_single_pick/*.yaml in the shared examples), so a reference template file
  applies to these objects unchanged;
- ``physics:mass`` 0.5 kg (``UsdPhysics.MassAPI``) and a physics material of static and dynamic
  friction 1.0, the values every InternDataEngine object USD authors
  (:mod:`harness.objects.usd_physics`);
- the grasps from the project's generator (``harness grasps generate``) in the object frame, in
  metres (the pick's ``grasp_scale`` 1, as the reference's files), 3000 rows as its sparse files.

The shapes and sizes are chosen, no public source: everyday sizes (boxes and tins of 3-15 cm,
bottles of 15-22 cm, balls of 5-8 cm) that span what the three grippers' openings (FR3 0.08 m,
Piper 0.10 m, R5a 0.088 m) can and cannot take.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from harness.objects import shapes
from harness.writes import write_file, write_npy

MESH_NAME = "Aligned_obj.usd"
GRASP_NAME = "Aligned_grasp_sparse.npy"
MILLIMETRES = 1000.0  # points per metre: the reference's pre-train-pick assets are in mm
REFERENCE_MASS_KG = 0.5  # physics:mass of every InternDataEngine object USD (usd_physics.py)
REFERENCE_FRICTION = 1.0  # static = dynamic friction of their physics material (usd_physics.py)


@dataclass(frozen=True)
class LibraryObject:
    """One object of the library: its group (the reference's category folder), name, builder."""

    group: str
    name: str
    build: Callable[[], trimesh.Trimesh]

    @property
    def relative_mesh(self) -> Path:
        return Path(self.group) / self.name / MESH_NAME


def _cm(value: float) -> str:
    return f"{value * 100:g}".replace(".", "p")


def _boxes() -> list[LibraryObject]:
    sizes = [
        (0.03, 0.03, 0.03), (0.04, 0.04, 0.04), (0.05, 0.05, 0.05), (0.06, 0.06, 0.06),
        (0.03, 0.05, 0.08), (0.04, 0.06, 0.10), (0.05, 0.08, 0.14), (0.03, 0.03, 0.12),
        (0.04, 0.04, 0.15), (0.06, 0.09, 0.03), (0.10, 0.15, 0.025), (0.05, 0.07, 0.05),
        (0.035, 0.09, 0.06), (0.08, 0.08, 0.04),
    ]  # fmt: skip
    return [
        LibraryObject("box", f"box_{'x'.join(_cm(s) for s in size)}", lambda s=size: shapes.box(s))
        for size in sizes
    ]


def _cans() -> list[LibraryObject]:
    sizes = [
        (0.02, 0.06), (0.025, 0.09), (0.03, 0.12), (0.033, 0.115), (0.037, 0.105),
        (0.04, 0.07), (0.028, 0.15), (0.022, 0.11), (0.035, 0.05), (0.045, 0.09),
    ]  # fmt: skip
    return [
        LibraryObject(
            "can", f"can_r{_cm(r)}_h{_cm(h)}", lambda r=r, h=h: shapes.can(radius=r, height=h)
        )
        for r, h in sizes
    ]


def _bottles() -> list[LibraryObject]:
    sizes = [
        (0.025, 0.011, 0.15), (0.03, 0.013, 0.205), (0.035, 0.014, 0.22), (0.028, 0.012, 0.18),
        (0.032, 0.015, 0.17), (0.022, 0.01, 0.16), (0.038, 0.016, 0.2), (0.027, 0.013, 0.21),
    ]  # fmt: skip
    return [
        LibraryObject(
            "bottle",
            f"bottle_r{_cm(r)}_h{_cm(h)}",
            lambda r=r, n=n, h=h: shapes.bottle(body_radius=r, neck_radius=n, height=h),
        )
        for r, n, h in sizes
    ]


def _balls() -> list[LibraryObject]:
    radii = [0.025, 0.028, 0.032, 0.035, 0.038, 0.04]
    return [LibraryObject("ball", f"ball_r{_cm(r)}", lambda r=r: shapes.ball(r)) for r in radii]


def _bananas() -> list[LibraryObject]:
    sizes = [
        (0.10, 1.4, (0.016, 0.014)), (0.12, 1.6, (0.018, 0.016)), (0.14, 1.5, (0.02, 0.017)),
        (0.11, 1.8, (0.017, 0.015)), (0.13, 1.3, (0.019, 0.018)), (0.15, 1.2, (0.015, 0.013)),
    ]  # fmt: skip
    return [
        LibraryObject(
            "banana",
            f"banana_a{_cm(a)}_t{_cm(2 * w[0])}",
            lambda a=a, t=t, w=w: shapes.banana(arc_radius=a, arc_angle=t, half_widths=w),
        )
        for a, t, w in sizes
    ]


def _mugs() -> list[LibraryObject]:
    sizes = [(0.035, 0.08), (0.04, 0.09), (0.045, 0.1), (0.03, 0.07), (0.038, 0.11), (0.042, 0.075)]
    return [
        LibraryObject(
            "mug", f"mug_r{_cm(r)}_h{_cm(h)}", lambda r=r, h=h: shapes.mug(radius=r, height=h)
        )
        for r, h in sizes
    ]


def library_objects() -> list[LibraryObject]:
    """The library, in a fixed order (the first ``count`` make a smaller library)."""
    families = [_boxes(), _cans(), _bottles(), _balls(), _bananas(), _mugs()]
    ordered: list[LibraryObject] = []
    for i in range(max(len(f) for f in families)):  # interleaved: a prefix mixes the shapes
        ordered.extend(f[i] for f in families if i < len(f))
    return ordered


def usd_text(mesh: trimesh.Trimesh) -> str:
    """The mesh as a USD layer (ASCII) in the reference's asset form: ``/World/Aligned`` a rigid
    body with ``physics:mass`` and a bound physics material, its points in millimetres."""
    from pxr import Gf, Usd, UsdGeom, UsdPhysics, UsdShade, Vt

    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 0.001)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    aligned = UsdGeom.Xform.Define(stage, "/World/Aligned")
    geom = UsdGeom.Mesh.Define(stage, "/World/Aligned/mesh")
    points = np.asarray(mesh.vertices, dtype=float) * MILLIMETRES
    geom.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, p)) for p in points]))
    faces = np.asarray(mesh.faces, dtype=int)
    geom.CreateFaceVertexCountsAttr(Vt.IntArray([3] * len(faces)))
    geom.CreateFaceVertexIndicesAttr(Vt.IntArray([int(i) for i in faces.reshape(-1)]))
    prim = aligned.GetPrim()
    UsdPhysics.RigidBodyAPI.Apply(prim)
    UsdPhysics.MassAPI.Apply(prim).CreateMassAttr(REFERENCE_MASS_KG)
    material = UsdShade.Material.Define(stage, "/World/Looks/physics")
    api = UsdPhysics.MaterialAPI.Apply(material.GetPrim())
    api.CreateStaticFrictionAttr(REFERENCE_FRICTION)
    api.CreateDynamicFrictionAttr(REFERENCE_FRICTION)
    UsdShade.MaterialBindingAPI.Apply(prim).Bind(
        material, UsdShade.Tokens.weakerThanDescendants, "physics"
    )
    return str(stage.GetRootLayer().ExportToString())


def build_library_object(spec: LibraryObject, out: Path, grasps: int = 3000, seed: int = 0) -> Path:
    """Write one object (mesh and grasps) under ``out``; returns its mesh path."""
    from harness.objects.graspgen import generate_grasps

    mesh = spec.build()
    folder = out / spec.group / spec.name
    path = write_file(folder / MESH_NAME, usd_text(mesh), root=out)
    result = generate_grasps(mesh, n=grasps, seed=seed)
    write_npy(folder / GRASP_NAME, result.grasps.astype(np.float32), root=out)
    return path


def build_library(
    out: Path, count: int | None = None, grasps: int = 3000, say: Callable[[str], None] = print
) -> list[Path]:
    """Build the first ``count`` objects of the library (all when None) under ``out``."""
    specs = library_objects()[: count or None]
    written = []
    for spec in specs:
        written.append(build_library_object(spec, out, grasps))
        say(f"{spec.group}/{spec.name}")
    return written
