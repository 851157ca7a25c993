"""Contact geometry of the grasp generator: surface samples, patch normals, ray casts, and the
force-closure score of a contact pair (Nguyen's antipodal condition)."""

from __future__ import annotations

import numpy as np
import trimesh

from harness.objects.graspgen.model import FRICTION_LEVELS


def force_closure_score(
    c1: np.ndarray, n1: np.ndarray, c2: np.ndarray, n2: np.ndarray
) -> np.ndarray:
    """Smallest mu in {0.1, ..., 1.0} making the two-contact grasp force-closure; NaN if none.

    Contacts c1, c2 with outward normals n1, n2: the pair is force-closure for friction mu when
    the segment c1->c2 lies inside the friction cone (half-angle atan mu) around -n1 at c1 and
    c2->c1 inside the cone around -n2 at c2 (Nguyen's antipodal condition).
    """
    axis = np.asarray(c2, dtype=float) - np.asarray(c1, dtype=float)
    length = np.linalg.norm(axis, axis=-1, keepdims=True)
    axis = axis / np.where(length > 0, length, 1.0)
    cos1 = -np.sum(axis * n1, axis=-1)
    cos2 = np.sum(axis * n2, axis=-1)
    cos = np.minimum(cos1, cos2)
    with np.errstate(invalid="ignore", divide="ignore"):
        mu_needed = np.sqrt(np.clip(1.0 - cos**2, 0.0, None)) / cos
    score = np.ceil(np.round(mu_needed * 10.0, 9)) / 10.0
    score = np.maximum(score, FRICTION_LEVELS[0])
    valid = (cos > 0) & (mu_needed <= FRICTION_LEVELS[-1] + 1e-9) & (length[..., 0] > 0)
    return np.where(valid, score, np.nan)


def perpendicular_basis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors completing each row of ``axis`` (unit, (N, 3)) to a right-handed frame."""
    helper = np.zeros_like(axis)
    helper[np.arange(len(axis)), np.argmin(np.abs(axis), axis=1)] = 1.0
    a = np.cross(axis, helper)
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b = np.cross(axis, a)
    return a, b


def sample_surface(
    mesh: trimesh.Trimesh, count: int, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """Area-weighted surface points and the face index of each (deterministic for ``rng``)."""
    areas = np.asarray(mesh.area_faces, dtype=np.float64)
    cumulative = np.cumsum(areas)
    faces = np.searchsorted(cumulative, rng.random(count) * cumulative[-1], side="right")
    faces = np.minimum(faces, len(areas) - 1)
    r1, r2 = np.sqrt(rng.random(count)), rng.random(count)
    tri = np.asarray(mesh.triangles)[faces]
    points = (
        (1 - r1)[:, None] * tri[:, 0]
        + (r1 * (1 - r2))[:, None] * tri[:, 1]
        + (r1 * r2)[:, None] * tri[:, 2]
    )
    return points, faces


class ContactNormals:
    """Outward normal of the contact patch around a surface point: the area-weighted mean of the
    face normals within ``radius`` (a finger pad's contact patch), which keeps scanned meshes'
    facet noise out of the friction-cone test. Faces larger than the patch contribute through
    the hit face's own normal, so flat faces of coarse meshes keep their exact normal."""

    def __init__(self, mesh: trimesh.Trimesh, radius: float = 0.003) -> None:
        # cKDTree comes from a compiled scipy module without type information.
        from scipy.spatial import cKDTree  # pyright: ignore[reportAttributeAccessIssue]

        self.radius = radius
        self.tree = cKDTree(np.asarray(mesh.triangles_center))
        self.weighted = np.asarray(mesh.face_normals) * np.asarray(mesh.area_faces)[:, None]
        self.areas = np.asarray(mesh.area_faces)

    def __call__(self, points: np.ndarray, face_normals: np.ndarray) -> np.ndarray:
        neighbours = self.tree.query_ball_point(points, self.radius)
        counts = np.fromiter((len(n) for n in neighbours), dtype=np.int64, count=len(points))
        flat = np.fromiter((i for n in neighbours for i in n), dtype=np.int64, count=counts.sum())
        owner = np.repeat(np.arange(len(points)), counts)
        total = np.zeros((len(points), 3))
        np.add.at(total, owner, self.weighted[flat])
        covered = np.bincount(owner, weights=self.areas[flat], minlength=len(points))
        own_weight = np.maximum(np.pi * self.radius**2 - covered, 0.0)
        total += own_weight[:, None] * face_normals
        norm = np.linalg.norm(total, axis=1, keepdims=True)
        return np.where(norm > 1e-12, total / np.where(norm > 0, norm, 1.0), face_normals)


class RayCaster:
    """First-hit ray casts against a triangle mesh with MuJoCo's mesh BVH (exact triangles,
    two-sided; the returned normal is the hit face's outward normal)."""

    def __init__(self, mesh: trimesh.Trimesh) -> None:
        import mujoco

        spec = mujoco.MjSpec()
        asset = spec.add_mesh()
        asset.name = "object"
        asset.uservert = np.asarray(mesh.vertices, dtype=np.float32).ravel()
        asset.userface = np.asarray(mesh.faces, dtype=np.int32).ravel()
        asset.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
        geom = spec.worldbody.add_geom()
        geom.type = mujoco.mjtGeom.mjGEOM_MESH
        geom.meshname = "object"
        self._mujoco = mujoco
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        mujoco.mj_kinematics(self.model, self.data)

    def first_hit(
        self, origins: np.ndarray, directions: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Distance to the first surface along each ray (-1 if none) and the face normal there."""
        ray = self._mujoco.mj_rayMesh
        model, data = self.model, self.data
        origins = np.ascontiguousarray(origins, dtype=np.float64)
        directions = np.ascontiguousarray(directions, dtype=np.float64)
        dist = np.empty(len(origins))
        normals = np.zeros((len(origins), 3))
        normal = np.zeros(3)
        for i in range(len(origins)):
            dist[i] = ray(model, data, 0, origins[i], directions[i], normal)
            normals[i] = normal
        return dist, normals

    def inside(self, points: np.ndarray) -> np.ndarray:
        """True where a point lies inside the closed mesh: the first surface a ray meets from
        there faces away from the point (parity-free, valid for closed meshes)."""
        directions = np.tile(
            np.array([0.5773502691896258, 0.5773502691896258, 0.5773502691896258]), (len(points), 1)
        )
        dist, normals = self.first_hit(points, directions)
        return (dist >= 0) & (np.sum(normals * directions, axis=1) > 0)
