"""CoACD in a child process, so a mesh that takes too long can be stopped.

CoACD is C++ and cannot be interrupted from Python: a 199 MB OBJ was still decomposing after
580 s at 1.8 GB. ``run_coacd_bounded`` runs it with ``python -m harness.objects.coacd_process``
(a plain subprocess, so it also works inside daemonic pool workers, which may not fork
multiprocessing children) and kills it after ``timeout_s``. The mesh goes in and the pieces come
back as ``.npz`` files in a temporary folder.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

# Chosen, no public source: the slowest bundled or InternData mesh takes ~35 s on first load.
COACD_TIMEOUT_S = 300.0


class CoacdTimeoutError(TimeoutError):
    """CoACD did not finish within the limit."""


def run_coacd_bounded(
    vertices: np.ndarray, faces: np.ndarray, kwargs: dict[str, Any], timeout_s: float
) -> list[tuple[np.ndarray, np.ndarray]]:
    """CoACD's convex pieces of the mesh, or ``CoacdTimeoutError`` after ``timeout_s``."""
    with tempfile.TemporaryDirectory(prefix="pick-harness-coacd-") as folder:
        mesh_file, pieces_file = Path(folder) / "mesh.npz", Path(folder) / "pieces.npz"
        np.savez(mesh_file, vertices=vertices, faces=faces)
        command = [sys.executable, "-m", __name__, str(mesh_file), str(pieces_file)]
        try:
            done = subprocess.run(
                [*command, json.dumps(kwargs)], capture_output=True, timeout=timeout_s, check=False
            )
        except subprocess.TimeoutExpired:
            raise CoacdTimeoutError(
                f"CoACD did not finish within {timeout_s:g} s (the limit per mesh): simplify "
                "the mesh (fewer faces)"
            ) from None
        if done.returncode != 0 or not pieces_file.is_file():
            tail = done.stderr.decode(errors="replace").strip().splitlines()[-1:] or ["no output"]
            raise RuntimeError(f"CoACD exited with code {done.returncode}: {tail[0][:200]}")
        with np.load(pieces_file) as data:
            count = int(data["count"])
            return [(data[f"v{i}"], data[f"f{i}"]) for i in range(count)]


def _main(mesh_file: str, pieces_file: str, kwargs_json: str) -> None:
    import coacd

    coacd.set_log_level("error")
    with np.load(mesh_file) as data:
        mesh = coacd.Mesh(np.asarray(data["vertices"], np.float64), np.asarray(data["faces"]))
    parts = coacd.run_coacd(mesh, **json.loads(kwargs_json))
    arrays: dict[str, Any] = {"count": np.array(len(parts))}
    for i, (v, f) in enumerate(parts):
        arrays[f"v{i}"] = np.asarray(v, dtype=np.float64)
        arrays[f"f{i}"] = np.asarray(f, dtype=np.int64)
    np.savez(pieces_file, **arrays)


if __name__ == "__main__":
    _main(*sys.argv[1:4])
