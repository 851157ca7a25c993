"""Mesh reading and validation: a mesh file -> a checked, scaled triangle mesh.

Formats: USD (``.usd``/``.usda``/``.usdc``/``.usdz``, read with usd-core) and OBJ, STL, GLB/GLTF,
PLY (read with trimesh). For USD the points of every ``UsdGeom.Mesh`` under ``/World/Aligned``
(the InternDataEngine layout; the whole stage otherwise) are used *raw* -- transforms between that
prim and the mesh are applied, but ``metersPerUnit`` is ignored, exactly as the reference does:
the example assets declare 0.01 yet their points are metres (docs/reference-pick-skill.md section
2). The task's
``scale`` multiplies the points; grasp points are never scaled here.
"""

from __future__ import annotations

import errno
from pathlib import Path

import numpy as np
import trimesh
from trimesh.resolvers import FilePathResolver

from harness.errors import InputFileError
from harness.reading import RefusedFileError, check_regular, read_capped, resolve_input

USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")
TRIMESH_SUFFIXES = (".obj", ".stl", ".glb", ".gltf", ".ply")
SUPPORTED_SUFFIXES = USD_SUFFIXES + TRIMESH_SUFFIXES
USD_OBJECT_PRIM = "/World/Aligned"
# Larger mesh files are refused before reading: a 199 MB OBJ took minutes to parse and then sat
# in CoACD for 580 s at 1.8 GB. Chosen, no public source: the InternData example meshes are
# < 5 MB and a graspable object needs far fewer than the ~10^6 faces 64 MiB holds.
MAX_MESH_BYTES = 64 * 1024 * 1024
# A graspable object fits in this cube (after ``scale``); a mesh in the wrong units (mm read as
# m) or with garbage coordinates (1e31 m) ran and counted as ordinary failures. Chosen, no
# public source: the largest InternData example object is under 0.5 m, the table about 1.5 m.
MAX_MESH_EXTENT_M = 10.0
# Sublayers / references of a USD file are followed at most this deep (each checked first).
MAX_USD_LAYER_DEPTH = 16


def check_usd_layers(path: Path) -> None:
    """Every layer a USD stage would open is a regular file under the size cap, checked
    *before* usd-core opens it: a FIFO sublayer made ``Usd.Stage.Open`` wait forever."""
    from pxr import Sdf

    seen: set[str] = set()
    pending = [(str(resolve_input(path, "mesh file")), 0)]
    while pending:
        layer_path, depth = pending.pop()
        if layer_path in seen:
            continue
        seen.add(layer_path)
        if depth > MAX_USD_LAYER_DEPTH:
            raise InputFileError(path, f"USD layers nest deeper than {MAX_USD_LAYER_DEPTH}")
        try:
            check_regular(layer_path, MAX_MESH_BYTES)
        except FileNotFoundError:
            if depth == 0:
                raise InputFileError(path, "mesh file not found") from None
            continue  # usd-core reports a missing sublayer itself (a warning)
        except (OSError, RefusedFileError) as exc:
            raise InputFileError(path, f"USD layer {layer_path}: {exc}") from None
        try:
            layer = Sdf.Layer.OpenAsAnonymous(layer_path)
        except Exception as exc:  # usd-core's parse errors (pxr.Tf.ErrorException)
            detail = str(exc).strip().splitlines()[-1][:200]
            raise InputFileError(path, f"cannot read USD layer {layer_path}: {detail}") from None
        if layer is None:
            continue
        base = Path(layer_path).parent
        for asset in layer.GetCompositionAssetDependencies():
            if asset and "://" not in asset and not asset.startswith("@"):
                child = Path(asset) if Path(asset).is_absolute() else base / asset
                try:
                    pending.append((str(child.resolve()), depth + 1))
                except RuntimeError:  # Path.resolve on a symlink loop
                    raise InputFileError(path, f"USD layer {child} is a symlink loop") from None


def _read_usd(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Raw points and triangulated faces of the meshes under /World/Aligned (or the stage)."""
    from pxr import Gf, Usd, UsdGeom

    check_usd_layers(path)
    try:
        stage = Usd.Stage.Open(str(path))
    except Exception as exc:
        raise InputFileError(path, f"cannot read USD stage: {str(exc).strip()[:200]}") from exc
    if stage is None:
        raise InputFileError(path, "cannot read USD stage")
    root = stage.GetPrimAtPath(USD_OBJECT_PRIM)
    if not root.IsValid():
        root = stage.GetPseudoRoot()
    prims = [prim for prim in Usd.PrimRange(root) if prim.IsA(UsdGeom.Mesh)]
    if not prims:
        raise InputFileError(path, f"no UsdGeom.Mesh prim under {root.GetPath()}")
    xform_cache = UsdGeom.XformCache(Usd.TimeCode.EarliestTime())
    root_to_world = (
        xform_cache.GetLocalToWorldTransform(root) if root != stage.GetPseudoRoot() else None
    )
    world_to_root = root_to_world.GetInverse() if root_to_world is not None else Gf.Matrix4d(1.0)
    all_vertices, all_faces, offset = [], [], 0
    for prim in prims:
        mesh = UsdGeom.Mesh(prim)
        time = Usd.TimeCode.EarliestTime()
        points = mesh.GetPointsAttr().Get(time)
        counts = mesh.GetFaceVertexCountsAttr().Get(time)
        indices = mesh.GetFaceVertexIndicesAttr().Get(time)
        if points is None or counts is None or indices is None or len(points) == 0:
            continue
        vertices = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        counts_arr = np.asarray(counts, dtype=np.int64)
        if counts_arr.size and counts_arr.min() < 0:
            raise InputFileError(path, f"{prim.GetPath()}: negative faceVertexCounts")
        if int(counts_arr.sum()) != len(indices):
            raise InputFileError(
                path,
                f"{prim.GetPath()}: faceVertexCounts sum to {int(counts_arr.sum())} but there "
                f"are {len(indices)} faceVertexIndices",
            )
        # USD matrices act on row vectors: p_root = p_mesh * M_mesh_world * M_world_root.
        to_root = np.asarray(xform_cache.GetLocalToWorldTransform(prim) * world_to_root)
        if not np.allclose(to_root, np.eye(4)):
            vertices = vertices @ to_root[:3, :3] + to_root[3, :3]
        faces = triangulate(counts_arr, np.asarray(indices, np.int64))
        if faces.size and (faces.min() < 0 or faces.max() >= len(vertices)):
            raise InputFileError(path, f"{prim.GetPath()}: face vertex index out of range")
        if mesh.GetOrientationAttr().Get() == UsdGeom.Tokens.leftHanded:
            faces = faces[:, ::-1]
        all_vertices.append(vertices)
        all_faces.append(faces + offset)
        offset += len(vertices)
    if not all_vertices:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
    return np.vstack(all_vertices), np.vstack(all_faces)


def triangulate(counts: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """Fan-triangulate polygons given USD-style face vertex counts and flat vertex indices."""
    if counts.sum() != len(indices):
        raise ValueError("face vertex counts do not match the number of indices")
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    n_tris = np.clip(counts - 2, 0, None)
    poly = np.repeat(np.arange(len(counts)), n_tris)
    k = np.arange(n_tris.sum()) - np.repeat(np.cumsum(n_tris) - n_tris, n_tris)
    base = starts[poly]
    return np.column_stack([indices[base], indices[base + k + 1], indices[base + k + 2]])


class CheckedResolver(FilePathResolver):
    """trimesh's file resolver under the read rule (``harness.reading``): every file a mesh
    pulls in (an OBJ's ``mtllib``, an MTL's ``map_Kd`` texture, a glTF's buffers and images)
    is read only if it is a regular file within ``MAX_MESH_BYTES``. A FIFO named by ``mtllib``
    or ``map_Kd`` made ``trimesh.load`` wait forever. trimesh swallows a failed include (it
    logs and goes on), so each refusal is kept in ``refused`` and raised after the load."""

    def __init__(self, source: str) -> None:
        super().__init__(source)
        self.refused: list[str] = []

    def get(self, name: str) -> bytes:
        try:
            target = self.absolute(name)
        except RuntimeError:  # a symlink loop
            self.refused.append(f"{name}: a symlink loop")
            raise
        try:
            return read_capped(target, MAX_MESH_BYTES)
        except RefusedFileError as exc:
            self.refused.append(f"{name} {exc}")
            raise
        except OSError as exc:
            if exc.errno == errno.ELOOP:
                self.refused.append(f"{name}: a symlink loop")
            raise


def _read_trimesh(path: Path) -> tuple[np.ndarray, np.ndarray]:
    resolver = CheckedResolver(str(path))
    try:
        loaded = trimesh.load(str(path), force="mesh", process=False, resolver=resolver)
    except Exception as exc:
        if resolver.refused:
            raise InputFileError(path, f"file the mesh includes: {resolver.refused[0]}") from None
        raise InputFileError(path, f"cannot read mesh: {str(exc).strip()[:200]}") from exc
    if resolver.refused:
        raise InputFileError(path, f"file the mesh includes: {resolver.refused[0]}")
    if not isinstance(loaded, trimesh.Trimesh):  # e.g. an empty scene
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
    return np.asarray(loaded.vertices, dtype=np.float64), np.asarray(loaded.faces, dtype=np.int64)


def read_mesh_arrays(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (V, 3) and triangles (F, 3) as stored in the file, before any checks or scale."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in SUPPORTED_SUFFIXES:
        raise InputFileError(
            path, f"unsupported mesh format {suffix or '(none)'!r}; use one of {SUPPORTED_SUFFIXES}"
        )
    try:
        size = check_regular(path)
    except FileNotFoundError:
        raise InputFileError(path, "mesh file not found") from None
    except RefusedFileError as exc:
        raise InputFileError(path, f"mesh file {exc}") from None
    except OSError as exc:
        raise InputFileError(path, f"cannot open mesh file: {exc.strerror}") from exc
    if size > MAX_MESH_BYTES:
        raise InputFileError(
            path,
            f"mesh file is {size / 2**20:.0f} MiB, above the limit of {MAX_MESH_BYTES / 2**20:.0f} "
            "MiB; simplify it (fewer faces) before use",
        )
    return _read_usd(path) if suffix in USD_SUFFIXES else _read_trimesh(path)


def load_mesh(path: str | Path, scale: tuple[float, float, float] | float = 1.0) -> trimesh.Trimesh:
    """Read, scale and validate a mesh: non-empty, finite, with volume. Errors name the file.

    Duplicate vertices are merged (USD meshes split them at UV seams); a closed mesh wound
    inside-out is turned outwards.
    """
    path = Path(path)
    vertices, faces = read_mesh_arrays(path)
    if len(vertices) == 0 or len(faces) == 0:
        raise InputFileError(path, "mesh is empty (no vertices or no faces)")
    bad = ~np.isfinite(vertices)
    if bad.any():
        rows = int(bad.any(axis=1).sum())
        raise InputFileError(path, f"mesh has {rows} vertices with NaN or infinite coordinates")
    scale_arr = np.broadcast_to(np.asarray(scale, dtype=np.float64), (3,))
    if not np.all(np.isfinite(scale_arr)) or np.any(scale_arr <= 0):
        raise InputFileError(path, f"scale must be positive and finite, got {scale_arr.tolist()}")
    extent = float(np.abs(vertices * scale_arr).max())
    if extent > MAX_MESH_EXTENT_M:
        raise InputFileError(
            path,
            f"mesh reaches {extent:.3g} m from its origin (after scale), above "
            f"{MAX_MESH_EXTENT_M:g} m for a graspable object; wrong units or a broken file?",
        )
    mesh = trimesh.Trimesh(vertices=vertices * scale_arr, faces=faces, process=True)
    mesh.remove_unreferenced_vertices()
    if len(mesh.faces) == 0:
        raise InputFileError(path, "mesh has no non-degenerate faces")
    if _hull_volume(mesh) <= 1e-12:
        raise InputFileError(
            path, "mesh has zero volume (its vertices lie in a plane or on a line)"
        )
    if mesh.is_watertight and mesh.is_winding_consistent and mesh.volume < 0:
        mesh.invert()
    return mesh


def _hull_volume(mesh: trimesh.Trimesh) -> float:
    centred = mesh.vertices - mesh.vertices.mean(axis=0)
    singular = np.linalg.svd(centred, compute_uv=False)
    if len(singular) < 3 or singular[2] <= 1e-9 * max(singular[0], 1e-30):
        return 0.0
    try:
        return float(mesh.convex_hull.volume)
    except Exception:  # qhull rejects (nearly) degenerate input
        return 0.0
