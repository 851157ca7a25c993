"""Mass properties of an object mesh: centre of mass and inertia of a uniform solid."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import trimesh


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
