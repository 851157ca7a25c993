"""Convex collision pieces of a mesh: a CoACD decomposition with an on-disk cache.

Collision geometry is a convex decomposition by CoACD with explicit, modest parameters (MuJoCo
pays per convex piece), cached on disk so that a worker loads it in milliseconds. Meshes that
are already convex skip CoACD; a CoACD failure falls back to the convex hull with a warning.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import tempfile
import warnings
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from harness.errors import InputFileError
from harness.files import safe_file_name
from harness.objects import coacd_process
from harness.objects.coacd_process import CoacdTimeoutError, run_coacd_bounded

LOG = logging.getLogger(__name__)

CACHE_FORMAT = 1  # bump when the cache file layout changes
CONVEX_VOLUME_RATIO = 0.995  # a watertight mesh this close to its hull's volume is convex

Piece = tuple[np.ndarray, np.ndarray]


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
    arrays: dict[str, Any] = {"count": np.array(len(pieces))}
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
    """Run CoACD (counted in ``DECOMPOSITION_RUNS``) and return its convex pieces; in a child
    process stopped after ``COACD_TIMEOUT_S`` (``CoacdTimeoutError``)."""
    global DECOMPOSITION_RUNS
    kwargs = asdict(params)
    if params.preprocess_mode == "auto":
        kwargs["preprocess_mode"] = "off" if mesh.is_watertight else "on"
    DECOMPOSITION_RUNS += 1
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    return run_coacd_bounded(vertices, faces, kwargs, coacd_process.COACD_TIMEOUT_S)


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
    path = cache_dir() / safe_file_name(key, ".npz")
    cached = _load_pieces(path) if path.is_file() else None
    if cached:
        return cached, "cache"
    # The first load of a mesh can take tens of seconds (35 s seen on an InternData bottle):
    # say so on stderr instead of looking hung (unconfigured logging prints warnings there).
    LOG.warning(
        "%s: convex decomposition with CoACD (%d faces; first load only, cached in %s) ...",
        source_name,
        len(mesh.faces),
        cache_dir(),
    )
    try:
        pieces = [p for p in run_coacd(mesh, params) if len(p[0]) >= 4 and len(p[1]) >= 4]
        if not pieces:
            raise RuntimeError("CoACD returned no pieces")
    except CoacdTimeoutError as exc:  # a clear error, not a silent hull: the mesh needs work
        raise InputFileError(source_name, str(exc), "mesh") from None
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
