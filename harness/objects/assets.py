"""Object assets: a mesh file -> validated triangle mesh, convex collision pieces, mass properties,
and the grasp annotation file that belongs to it.

Formats: USD (``.usd``/``.usda``/``.usdc``/``.usdz``, read with usd-core) and OBJ, STL, GLB/GLTF,
PLY (read with trimesh). For USD the points of every ``UsdGeom.Mesh`` under ``/World/Aligned``
(the InternDataEngine layout; the whole stage otherwise) are used *raw* -- transforms between that
prim and the mesh are applied, but ``metersPerUnit`` is ignored, exactly as the reference does:
the example assets declare 0.01 yet their points are metres
(docs/reference-pick-skill.md section 2). The task's
``scale`` multiplies the points; grasp points are never scaled here.

Collision geometry is a convex decomposition by CoACD with explicit, modest parameters (MuJoCo
pays per convex piece), cached on disk so that a worker loads it in milliseconds. Meshes that
are already convex skip CoACD; a CoACD failure falls back to the convex hull with a warning.

Grasp file rule, first existing wins: an explicit path; ``<mesh folder>/<npy_name>`` (default
``Aligned_grasp_sparse.npy``, the reference rule); ``<mesh folder>/<mesh stem>_grasps.npy``;
``<mesh folder>/grasps.npy`` (the default object set's name).
"""

from __future__ import annotations

import copy
import functools
import hashlib
import json
import os
import tempfile
import warnings
from dataclasses import asdict, dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
import yaml

from harness.errors import InputFileError

USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")
TRIMESH_SUFFIXES = (".obj", ".stl", ".glb", ".gltf", ".ply")
SUPPORTED_SUFFIXES = USD_SUFFIXES + TRIMESH_SUFFIXES
DEFAULT_NPY_NAME = "Aligned_grasp_sparse.npy"
USD_OBJECT_PRIM = "/World/Aligned"
CACHE_FORMAT = 1  # bump when the cache file layout changes
CONVEX_VOLUME_RATIO = 0.995  # a watertight mesh this close to its hull's volume is convex

Piece = tuple[np.ndarray, np.ndarray]


# --------------------------------------------------------------------------------------------
# Mesh reading and validation


def _read_usd(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Raw points and triangulated faces of the meshes under /World/Aligned (or the stage)."""
    from pxr import Gf, Usd, UsdGeom

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
        # USD matrices act on row vectors: p_root = p_mesh * M_mesh_world * M_world_root.
        to_root = np.asarray(xform_cache.GetLocalToWorldTransform(prim) * world_to_root)
        if not np.allclose(to_root, np.eye(4)):
            vertices = vertices @ to_root[:3, :3] + to_root[3, :3]
        faces = triangulate(np.asarray(counts, dtype=np.int64), np.asarray(indices, np.int64))
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


def _read_trimesh(path: Path) -> tuple[np.ndarray, np.ndarray]:
    try:
        loaded = trimesh.load(str(path), force="mesh", process=False)
    except Exception as exc:
        raise InputFileError(path, f"cannot read mesh: {str(exc).strip()[:200]}") from exc
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
    if not path.is_file():
        raise InputFileError(path, "mesh file not found")
    try:
        with path.open("rb"):
            pass
    except OSError as exc:
        raise InputFileError(path, f"cannot open mesh file: {exc.strerror}") from exc
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


# --------------------------------------------------------------------------------------------
# Convex decomposition with an on-disk cache


@dataclass(frozen=True)
class CoacdParams:
    """CoACD settings, chosen for speed over fidelity: at most 12 pieces (MuJoCo pays per piece),
    concavity threshold 0.08 (CoACD's default is 0.05) and a lighter tree search than CoACD's
    defaults, which take minutes on a 5,000-vertex mesh. ``preprocess_mode="auto"`` here means
    CoACD's manifold remeshing is off for closed meshes (they need none; it costs most of the
    time) and on for open ones."""

    threshold: float = 0.08
    max_convex_hull: int = 12
    preprocess_mode: str = "auto"
    preprocess_resolution: int = 30
    resolution: int = 500
    mcts_nodes: int = 8
    mcts_iterations: int = 30
    mcts_max_depth: int = 2
    max_ch_vertex: int = 64
    seed: int = 0


# Number of CoACD runs in this process (tests use it to show the cache works).
DECOMPOSITION_RUNS = 0


def cache_dir() -> Path:
    """``$PICK_HARNESS_CACHE/coacd``, else ``$XDG_CACHE_HOME/pick-harness/coacd``, else
    ``~/.cache/pick-harness/coacd``."""
    root = os.environ.get("PICK_HARNESS_CACHE")
    if root:
        return Path(root).expanduser() / "coacd"
    xdg = os.environ.get("XDG_CACHE_HOME")
    base = Path(xdg).expanduser() if xdg else Path.home() / ".cache"
    return base / "pick-harness" / "coacd"


def _coacd_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("coacd")
    except PackageNotFoundError:
        return "unknown"


def mesh_hash(vertices: np.ndarray, faces: np.ndarray) -> str:
    """SHA-256 of the mesh arrays (float64 / int64, little-endian)."""
    digest = hashlib.sha256()
    digest.update(np.ascontiguousarray(vertices, dtype="<f8").tobytes())
    digest.update(np.ascontiguousarray(faces, dtype="<i8").tobytes())
    return digest.hexdigest()


def decomposition_key(
    content_hash: str, scale: tuple[float, float, float], params: CoacdParams
) -> str:
    """Cache key from the unscaled mesh content, the scale and every CoACD parameter."""
    payload = {
        "format": CACHE_FORMAT,
        "mesh": content_hash,
        "scale": [float(s) for s in scale],
        "coacd": _coacd_version(),
        "params": asdict(params),
    }
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()[:32]


def _save_pieces(path: Path, pieces: list[Piece]) -> None:
    """Write atomically: parallel workers may decompose the same mesh at the same time."""
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays: dict[str, np.ndarray] = {"count": np.array(len(pieces))}
    for i, (vertices, faces) in enumerate(pieces):
        arrays[f"vertices_{i}"] = vertices
        arrays[f"faces_{i}"] = faces
    fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as handle:
            np.savez(handle, **arrays)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _load_pieces(path: Path) -> list[Piece] | None:
    try:
        with np.load(path) as data:
            count = int(data["count"])
            return [(data[f"vertices_{i}"], data[f"faces_{i}"]) for i in range(count)]
    except Exception:  # missing, truncated or from another format: recompute
        return None


def _hull_piece(mesh: trimesh.Trimesh) -> Piece:
    hull = mesh.convex_hull
    return np.asarray(hull.vertices, dtype=np.float64), np.asarray(hull.faces, dtype=np.int64)


def is_convex_solid(mesh: trimesh.Trimesh) -> bool:
    """A closed mesh whose volume is (almost) that of its convex hull."""
    if not (mesh.is_watertight and mesh.is_winding_consistent) or mesh.volume <= 0:
        return False
    return mesh.volume >= CONVEX_VOLUME_RATIO * mesh.convex_hull.volume


def run_coacd(mesh: trimesh.Trimesh, params: CoacdParams) -> list[Piece]:
    """Run CoACD (counted in ``DECOMPOSITION_RUNS``) and return its convex pieces."""
    global DECOMPOSITION_RUNS
    import coacd

    coacd.set_log_level("error")
    kwargs = asdict(params)
    if params.preprocess_mode == "auto":
        kwargs["preprocess_mode"] = "off" if mesh.is_watertight else "on"
    DECOMPOSITION_RUNS += 1
    parts = coacd.run_coacd(
        coacd.Mesh(np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces)), **kwargs
    )
    return [(np.asarray(v, dtype=np.float64), np.asarray(f, dtype=np.int64)) for v, f in parts]


def collision_pieces(
    mesh: trimesh.Trimesh,
    key: str,
    params: CoacdParams,
    source_name: str | Path,
) -> tuple[list[Piece], str]:
    """Convex pieces of ``mesh`` and where they came from: ``convex`` (the mesh is convex),
    ``cache``, ``coacd`` (computed now and cached) or ``convex_hull`` (CoACD failed)."""
    if is_convex_solid(mesh):
        return [_hull_piece(mesh)], "convex"
    path = cache_dir() / f"{key}.npz"
    cached = _load_pieces(path) if path.is_file() else None
    if cached:
        return cached, "cache"
    try:
        pieces = [p for p in run_coacd(mesh, params) if len(p[0]) >= 4 and len(p[1]) >= 4]
        if not pieces:
            raise RuntimeError("CoACD returned no pieces")
    except Exception as exc:
        warnings.warn(
            f"{source_name}: convex decomposition failed ({exc}); using the convex hull",
            RuntimeWarning,
            stacklevel=3,
        )
        return [_hull_piece(mesh)], "convex_hull"
    try:
        _save_pieces(path, pieces)
    except OSError as exc:
        warnings.warn(f"cannot write the CoACD cache {path}: {exc}", RuntimeWarning, stacklevel=3)
    return pieces, "coacd"


# --------------------------------------------------------------------------------------------
# Mass properties


def mass_properties(
    mesh: trimesh.Trimesh, mass: float, source_name: str | Path = "mesh"
) -> tuple[np.ndarray, np.ndarray]:
    """Centre of mass and inertia (3x3, about the COM) of a uniform solid of the given mass.

    An open or inconsistently wound mesh has no meaningful volume; its convex hull is used instead
    (with a warning), which over-estimates the inertia of concave objects a little.
    """
    solid = mesh
    if not (mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0):
        warnings.warn(
            f"{source_name}: mesh is not a closed solid; mass properties use its convex hull",
            RuntimeWarning,
            stacklevel=3,
        )
        solid = mesh.convex_hull
    props = solid.mass_properties  # at density 1: props.mass is the volume
    inertia = np.asarray(props.inertia, dtype=np.float64) * (mass / props.mass)
    inertia = 0.5 * (inertia + inertia.T)
    eigen = np.linalg.eigvalsh(inertia)
    if eigen.min() <= 0:  # numerically flat solids: keep MuJoCo's inertia positive definite
        inertia = inertia + np.eye(3) * max(1e-9, 1e-6 * eigen.max())
    return np.asarray(props.center_mass, dtype=np.float64), inertia


# --------------------------------------------------------------------------------------------
# Grasp files and default objects


def find_grasp_file(mesh_path: Path, npy_name: str = DEFAULT_NPY_NAME) -> Path | None:
    """The grasp file next to ``mesh_path`` by the naming rule (module docstring), or None.

    A non-default ``npy_name`` that does not exist is an error: the user asked for that file.
    """
    folder = mesh_path.parent
    named = folder / npy_name
    if named.is_file():
        return named
    if npy_name != DEFAULT_NPY_NAME:
        raise InputFileError(named, f"grasp file not found (npy_name {npy_name!r})", key="npy_name")
    for candidate in (folder / f"{mesh_path.stem}_grasps.npy", folder / "grasps.npy"):
        if candidate.is_file():
            return candidate
    return None


def repo_root() -> Path:
    """The project checkout this package lives in (the folder holding ``harness/``)."""
    return Path(__file__).resolve().parents[2]


def default_objects_dir() -> Path:
    return repo_root() / "tasks" / "objects"


def list_default_objects() -> list[str]:
    """Names of the default objects (folders of tasks/objects holding an object.yaml)."""
    root = default_objects_dir()
    if not root.is_dir():
        return []
    return sorted(p.parent.name for p in root.glob("*/object.yaml"))


def load_object_info(name: str) -> dict[str, Any]:
    """The parsed ``tasks/objects/<name>/object.yaml`` of a default object (a fresh copy)."""
    path = default_objects_dir() / name / "object.yaml"
    if not path.is_file():
        raise InputFileError(
            path, f"no default object named {name!r}; available: {list_default_objects()}"
        )
    return copy.deepcopy(_parse_object_info(path, path.stat().st_mtime_ns))


@functools.lru_cache(maxsize=64)
def _parse_object_info(path: Path, mtime_ns: int) -> dict[str, Any]:
    """Parse once per file version: episodes ask for it several times each (scene key, reset)."""
    del mtime_ns  # part of the cache key only
    try:
        info = yaml.safe_load(path.read_text(encoding="utf-8"))
    except yaml.YAMLError as exc:
        raise InputFileError(path, f"invalid YAML: {exc}") from exc
    if not isinstance(info, dict):
        raise InputFileError(path, "expected a mapping")
    return info


def resolve_mesh(mesh: str, base_dir: Path) -> Path:
    """A mesh given as a path (absolute, or relative to ``base_dir``) or as the name of a default
    object under tasks/objects/<name>/ -> the mesh file path."""
    candidate = Path(mesh).expanduser()
    if not candidate.is_absolute():
        candidate = Path(base_dir) / candidate
    if candidate.is_file():
        return candidate
    if "/" not in mesh and "\\" not in mesh and (default_objects_dir() / mesh).is_dir():
        info = load_object_info(mesh)
        mesh_file = default_objects_dir() / mesh / str(info.get("mesh", f"{mesh}.obj"))
        if not mesh_file.is_file():
            raise InputFileError(mesh_file, f"default object {mesh!r} has no mesh file", "mesh")
        return mesh_file
    raise InputFileError(
        candidate,
        f"mesh file not found, and {mesh!r} is not a default object "
        f"(available: {list_default_objects()})",
        key="mesh",
    )


# --------------------------------------------------------------------------------------------
# The asset


@dataclass
class ObjectAsset:
    """A graspable object: its mesh (object frame, metres), convex collision pieces, mass
    properties, friction, and the path of its grasp annotations (None when there is none)."""

    path: Path
    scale: tuple[float, float, float]
    mesh: trimesh.Trimesh
    collision_pieces: list[Piece]
    collision_source: str
    mass: float
    inertia: np.ndarray
    center_of_mass: np.ndarray
    friction: float
    grasp_path: Path | None
    coacd_params: CoacdParams = field(default_factory=CoacdParams)

    @classmethod
    def load(
        cls,
        mesh_path: str | Path,
        scale: tuple[float, float, float] | float = (1.0, 1.0, 1.0),
        grasps: str | Path | None = None,
        npy_name: str = DEFAULT_NPY_NAME,
        mass: float = 0.1,
        friction: float = 1.0,
        coacd_params: CoacdParams | None = None,
    ) -> ObjectAsset:
        """Load and validate a mesh, its collision pieces (cached) and locate its grasp file."""
        path = Path(mesh_path)
        scale3 = tuple(float(s) for s in np.broadcast_to(np.asarray(scale, dtype=float), (3,)))
        if not (np.isfinite(mass) and mass > 0):
            raise InputFileError(path, f"mass must be positive, got {mass}", key="mass")
        if not (np.isfinite(friction) and friction > 0):
            raise InputFileError(path, f"friction must be positive, got {friction}", "friction")
        mesh = load_mesh(path, scale3)
        params = coacd_params or CoacdParams()
        unscaled = mesh.vertices / np.asarray(scale3)
        key = decomposition_key(mesh_hash(unscaled, mesh.faces), scale3, params)
        pieces, source = collision_pieces(mesh, key, params, path)
        center_of_mass, inertia = mass_properties(mesh, mass, path)
        if grasps is not None:
            grasp_path: Path | None = Path(grasps)
            if not grasp_path.is_absolute() and not grasp_path.is_file():
                grasp_path = path.parent / grasp_path
            if not grasp_path.is_file():
                raise InputFileError(grasps, "grasp file not found", key="grasps")
        else:
            grasp_path = find_grasp_file(path, npy_name)
        return cls(
            path=path,
            scale=scale3,  # type: ignore[arg-type]
            mesh=mesh,
            collision_pieces=pieces,
            collision_source=source,
            mass=float(mass),
            inertia=inertia,
            center_of_mass=center_of_mass,
            friction=float(friction),
            grasp_path=grasp_path,
            coacd_params=params,
        )

    @property
    def vertices(self) -> np.ndarray:
        return np.asarray(self.mesh.vertices)

    @property
    def faces(self) -> np.ndarray:
        return np.asarray(self.mesh.faces)

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3): min and max corner in the object frame."""
        return np.asarray(self.mesh.bounds)

    @property
    def extents(self) -> np.ndarray:
        return np.asarray(self.mesh.extents)

    @cached_property
    def grasp_count(self) -> int | None:
        """Rows in the grasp file (read lazily, memory-mapped), or None without a file."""
        if self.grasp_path is None:
            return None
        try:
            return int(np.load(self.grasp_path, mmap_mode="r").shape[0])
        except Exception as exc:
            raise InputFileError(self.grasp_path, f"cannot read grasp file: {exc}") from exc
