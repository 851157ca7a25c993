"""Object assets: a mesh file -> validated triangle mesh, convex collision pieces, mass properties,
and the grasp annotation file that belongs to it; plus the default object set under tasks/objects.

Mesh reading lives in :mod:`harness.objects.meshes`, the cached convex decomposition in
:mod:`harness.objects.decomposition`, mass properties in :mod:`harness.objects.mass`.

Grasp file rule, first existing wins: an explicit path; ``<mesh folder>/<npy_name>`` (default
``Aligned_grasp_sparse.npy``, the reference rule); ``<mesh folder>/<mesh stem>_grasps.npy``;
``<mesh folder>/grasps.npy`` (the default object set's name).
"""

from __future__ import annotations

import copy
import functools
import os
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
import yaml

from harness.errors import InputFileError
from harness.files import MAX_CONFIG_BYTES, read_capped
from harness.grasps.grasp_set import MAX_GRASP_BYTES
from harness.objects.decomposition import (
    CoacdParams,
    Piece,
    collision_pieces,
    decomposition_key,
    mesh_hash,
)
from harness.objects.mass import mass_properties
from harness.objects.meshes import load_mesh
from harness.objects.usd_physics import read_usd_physics
from harness.reading import check_input, load_npy

DEFAULT_NPY_NAME = "Aligned_grasp_sparse.npy"
DEFAULT_MASS = 0.1  # kg, chosen (no public source) for meshes that author none
DEFAULT_FRICTION = 1.0  # MuJoCo's default sliding friction


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


@functools.lru_cache(maxsize=1)
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
        info = yaml.safe_load(read_capped(path, MAX_CONFIG_BYTES).decode("utf-8"))
    except yaml.YAMLError as exc:
        raise InputFileError(path, f"invalid YAML: {exc}") from exc
    except (OSError, ValueError) as exc:  # a FIFO, a device, too large, not UTF-8
        raise InputFileError(path, f"cannot read: {exc}") from None
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
    if os.path.lexists(candidate):  # there, but no regular file: say what it is (a FIFO, a loop)
        check_input(candidate, None, "mesh file")
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
        mass: float | None = None,
        friction: float | None = None,
        coacd_params: CoacdParams | None = None,
    ) -> ObjectAsset:
        """Load and validate a mesh, its collision pieces (cached) and locate its grasp file.

        ``mass`` / ``friction`` None: what the USD authors (``harness.objects.usd_physics``),
        else ``DEFAULT_MASS`` / ``DEFAULT_FRICTION``.
        """
        path = Path(mesh_path)
        if mass is None or friction is None:
            authored = read_usd_physics(path)
            mass = (authored.mass or DEFAULT_MASS) if mass is None else mass
            friction = (authored.friction or DEFAULT_FRICTION) if friction is None else friction
        sx, sy, sz = (float(s) for s in np.broadcast_to(np.asarray(scale, dtype=float), (3,)))
        scale3 = (sx, sy, sz)
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
            scale=scale3,
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
        array = load_npy(self.grasp_path, MAX_GRASP_BYTES, what="grasp file", mmap=True)
        if not isinstance(array, np.ndarray) or array.ndim == 0:  # an .npz archive, a scalar
            raise InputFileError(self.grasp_path, "cannot read grasp file: not one N x 17 array")
        return int(array.shape[0])
