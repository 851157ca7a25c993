"""Antipodal grasp annotations for any mesh, in the GraspNet / InternDataEngine N x 17 layout.

Row layout (docs/reference-pick-skill.md section 2): score, width, height, depth,
R_g (3x3, row-major),
translation, object id. GraspNet axes: g_x approach, g_y closing (width) direction, g_z = g_x x g_y.

Convention, measured on the shared InternDataEngine example files (tests/test_graspgen.py checks
it): the translation is a point on the object surface where the approach line enters the object
(the surface normal there opposes g_x); the fingertips sit ``depth`` beyond it along g_x (the
reference puts the TCP at ``translation + depth * g_x`` and the EE origin ``tcp_offset - depth``
behind the translation); the fingers are GraspNet's (6 cm long, 2 cm high = the height column) and
``width`` is the opening at which they touch the object: the object's largest |y| inside the
finger slab is width / 2 (median ratio 1.001 over the examples). Here the gripper is centred on
the contact pair, so the contacts are ``translation + s * g_x -/+ (width / 2) * g_y`` with
``s <= depth - tip_margin``. (The examples are not centred: their contacts are not at +-width/2.)

Algorithm (vectorised numpy; exact ray casts with MuJoCo's mesh BVH, exact box-vs-mesh collision
with coal, the FCL successor placo already installs):
1. sample surface points c1 (area-weighted) and a closing direction u inside a cone around the
   inward normal; c2 = first surface point along u (rays from c1);
2. score = the smallest friction coefficient mu in {0.1, ..., 1.0} for which the pair is
   force-closure: the segment c1-c2 lies within both friction cones (lower is better);
3. for each pair, approach directions g_x around the closing axis g_y = u; the translation is the
   exit point of a ray from the midpoint along -g_x; depth is the shallowest of {0.005, 0.01,
   0.02, 0.03, 0.04} that puts the fingertips at least ``tip_margin`` beyond the contacts (the
   contacts sit near the fingertips, the palm as far from the object as the fingers allow);
4. candidates in (score, random) order are kept when a parallel-jaw gripper (two finger boxes
   reaching from just outside the contacts to ``width / 2 + finger_thickness``, a palm box with an
   approach clearance behind it) neither touches the mesh nor sits inside it. The finger boxes
   starting ``contact_tolerance`` outside the contacts make the contacts the first points the
   closing fingers meet.
Deterministic for a seed: same mesh, parameters and seed give a byte-identical file.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

DEPTHS = (0.005, 0.01, 0.02, 0.03, 0.04)
FRICTION_LEVELS = tuple(round(0.1 * k, 1) for k in range(1, 11))
GRASP_HEIGHT = 0.02
OBJECT_ID = -1.0
RAY_EPSILON = 1e-6


@dataclass(frozen=True)
class GripperModel:
    """Parallel-jaw gripper as boxes in the grasp frame (GraspNet's model: fingers 6 cm long,
    1 cm thick, 2 cm high; a 1 cm palm with 5 cm of approach clearance behind it)."""

    finger_length: float = 0.06
    finger_thickness: float = 0.01
    height: float = GRASP_HEIGHT
    palm_thickness: float = 0.01
    approach_clearance: float = 0.05

    def boxes(
        self, width: float, depth: float, inner_half_width: float
    ) -> list[tuple[np.ndarray, np.ndarray]]:
        """(centre, full size) of the left finger, right finger and palm in the grasp frame.

        Fingers span x in [depth - finger_length, depth] and |y| from ``inner_half_width`` to
        ``width / 2 + finger_thickness``; the palm (with its clearance) lies behind them.
        """
        outer = max(0.5 * width, inner_half_width) + self.finger_thickness
        x0, x1 = depth - self.finger_length, depth
        finger_size = np.array([x1 - x0, outer - inner_half_width, self.height])
        y_mid = 0.5 * (outer + inner_half_width)
        palm_back = x0 - self.palm_thickness - self.approach_clearance
        return [
            (np.array([0.5 * (x0 + x1), -y_mid, 0.0]), finger_size),
            (np.array([0.5 * (x0 + x1), y_mid, 0.0]), finger_size.copy()),
            (
                np.array([0.5 * (palm_back + x0), 0.0, 0.0]),
                np.array([x0 - palm_back, 2 * outer, self.height]),
            ),
        ]


@dataclass(frozen=True)
class GraspGenParams:
    """Generator settings; the defaults follow the reference (max width 0.1 m, 3000 grasps)."""

    max_width: float = 0.1
    # Stored width = contact distance + 2 * clearance. 0 is the reference's definition (measured
    # on the example files): the opening at which the fingers touch the object in their slab.
    clearance: float = 0.0
    contact_tolerance: float = 0.002  # finger boxes start this far outside the contacts
    tip_margin: float = 0.005  # contacts at least this far behind the fingertip line
    min_contact_distance: float = 0.002
    contact_patch_radius: float = 0.003  # normals are averaged over this patch
    cone_half_angle: float = math.atan(0.3)  # spread of the sampled closing directions
    approach_angles: int = 12  # approach directions tried per contact pair
    grasps_per_pair: int = 4  # at most this many approaches kept per pair (spread)
    pairs_per_round: int = 0  # contact pairs sampled per round; 0: max(10 n, 5000)
    max_rounds: int = 3  # more rounds only when a round yields fewer than n grasps
    batch_pairs: int = 500  # pairs expanded into approach candidates at a time
    depths: tuple[float, ...] = DEPTHS
    gripper: GripperModel = field(default_factory=GripperModel)


@dataclass
class GraspAnnotations:
    """Generated rows plus, per row, the contact points and normals they were built from."""

    grasps: np.ndarray  # (N, 17) float32, sorted by score
    contacts: np.ndarray  # (N, 2, 3): c1 (on the -g_y side) and c2, object frame
    normals: np.ndarray  # (N, 2, 3): outward surface normals at c1 and c2
    stats: dict[str, Any]

    def save(self, path: str | Path) -> Path:
        return save_grasps(path, self.grasps)


def save_grasps(path: str | Path, grasps: np.ndarray) -> Path:
    """Write an N x 17 float32 grasp file (``np.save``; byte-identical for identical arrays)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("wb") as handle:
        np.save(handle, np.ascontiguousarray(grasps, dtype=np.float32))
    return path


# --------------------------------------------------------------------------------------------
# Geometry helpers


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


def _perpendicular_basis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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


class GripperCollision:
    """Exact gripper-box versus mesh collision with coal (BVH over the triangles)."""

    def __init__(self, mesh: trimesh.Trimesh) -> None:
        import coal

        self._coal = coal
        bvh = coal.BVHModelOBBRSS()
        bvh.beginModel(len(mesh.faces), len(mesh.vertices))
        bvh.addVertices(np.asarray(mesh.vertices, dtype=np.float64))
        bvh.addTriangles(np.asarray(mesh.faces, dtype=np.int32))
        bvh.endModel()
        self.bvh = bvh
        self.identity = coal.Transform3s()
        self.request = coal.CollisionRequest()
        self.result = coal.CollisionResult()

    def box_hits(self, rotation: np.ndarray, centre: np.ndarray, size: np.ndarray) -> bool:
        """True when the box (object-frame rotation and centre, full size) touches a triangle."""
        coal = self._coal
        self.result.clear()
        box = coal.Box(float(size[0]), float(size[1]), float(size[2]))
        pose = coal.Transform3s(rotation, centre)
        return bool(coal.collide(self.bvh, self.identity, box, pose, self.request, self.result))


def grasp_boxes(
    grasp: np.ndarray, gripper: GripperModel, inner_half_width: float
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Object-frame (rotation, centre, size) of the gripper boxes of one N x 17 row."""
    rotation = np.asarray(grasp[4:13], dtype=np.float64).reshape(3, 3)
    translation = np.asarray(grasp[13:16], dtype=np.float64)
    return [
        (rotation, translation + rotation @ centre, size)
        for centre, size in gripper.boxes(float(grasp[1]), float(grasp[3]), inner_half_width)
    ]


# --------------------------------------------------------------------------------------------
# The generator


def _sample_pairs(
    mesh: trimesh.Trimesh,
    rays: RayCaster,
    normals: ContactNormals,
    count: int,
    rng: np.random.Generator,
    p: GraspGenParams,
) -> dict[str, np.ndarray]:
    """Contact pairs that are force-closure for mu <= 1 and fit the maximum width."""
    c1, face = sample_surface(mesh, count, rng)
    n1 = np.asarray(mesh.face_normals, dtype=np.float64)[face]
    theta = p.cone_half_angle * rng.random(count) ** 2
    phi = 2 * np.pi * rng.random(count)
    a, b = _perpendicular_basis(-n1)
    u = (
        np.cos(theta)[:, None] * -n1
        + (np.sin(theta) * np.cos(phi))[:, None] * a
        + (np.sin(theta) * np.sin(phi))[:, None] * b
    )
    dist, n2 = rays.first_hit(c1 + RAY_EPSILON * u, u)
    dist = np.where(dist >= 0, dist + RAY_EPSILON, -1.0)
    c2 = c1 + dist[:, None] * u
    hit = dist >= 0
    n1 = normals(c1, n1)
    n2[hit] = normals(c2[hit], n2[hit])
    score = force_closure_score(c1, n1, c2, n2)
    keep = (
        (dist >= p.min_contact_distance)
        & (dist + 2 * p.clearance <= p.max_width + 1e-12)
        & np.isfinite(score)
    )
    return {
        "c1": c1[keep],
        "c2": c2[keep],
        "n1": n1[keep],
        "n2": n2[keep],
        "axis": u[keep],
        "distance": dist[keep],
        "score": score[keep],
    }


def _approach_candidates(
    pairs: dict[str, np.ndarray], rays: RayCaster, rng: np.random.Generator, p: GraspGenParams
) -> dict[str, np.ndarray]:
    """Approach directions around each pair's closing axis, entry points and depths."""
    n_pairs, k = len(pairs["score"]), p.approach_angles
    a, b = _perpendicular_basis(pairs["axis"])
    offset = rng.random(n_pairs)
    angles = 2 * np.pi * (np.arange(k)[None, :] + offset[:, None]) / k  # (P, K)
    pair_index = np.repeat(np.arange(n_pairs), k)
    cos, sin = np.cos(angles).ravel(), np.sin(angles).ravel()
    approach = cos[:, None] * a[pair_index] + sin[:, None] * b[pair_index]
    midpoint = 0.5 * (pairs["c1"] + pairs["c2"])[pair_index]
    entry, _ = rays.first_hit(midpoint, -approach)
    depths = np.asarray(p.depths)
    allowed = (entry[:, None] >= 0) & (depths[None, :] >= entry[:, None] + p.tip_margin)
    # the shallowest allowed depth: contacts just behind the fingertips, palm far from the object
    chosen = np.argmax(allowed, axis=1)
    keep = allowed.any(axis=1)
    return {
        "pair": pair_index[keep],
        "approach": approach[keep],
        "translation": (midpoint - entry[:, None] * approach)[keep],
        "depth": depths[chosen][keep],
        "score": pairs["score"][pair_index][keep],
    }


def _rows(
    pairs: dict[str, np.ndarray], cand: dict[str, np.ndarray], p: GraspGenParams
) -> np.ndarray:
    """N x 17 float64 rows for the candidates."""
    g_x = cand["approach"]
    g_y = pairs["axis"][cand["pair"]]
    g_z = np.cross(g_x, g_y)
    rotation = np.stack([g_x, g_y, g_z], axis=2)  # columns are the grasp axes
    rows = np.empty((len(g_x), 17))
    rows[:, 0] = cand["score"]
    rows[:, 1] = pairs["distance"][cand["pair"]] + 2 * p.clearance
    rows[:, 2] = p.gripper.height
    rows[:, 3] = cand["depth"]
    rows[:, 4:13] = rotation.reshape(-1, 9)
    rows[:, 13:16] = cand["translation"]
    rows[:, 16] = OBJECT_ID
    return rows


def generate_grasps(
    mesh: trimesh.Trimesh,
    n: int = 3000,
    seed: int = 0,
    params: GraspGenParams | None = None,
) -> GraspAnnotations:
    """Up to ``n`` collision-free antipodal grasps for ``mesh`` (object frame, metres).

    Each round samples a pool of contact pairs, orders them by (score, random), and expands the
    best pairs into approach candidates batch by batch until ``n`` grasps pass the gripper check,
    so the file holds the best-scoring grasps the pool offers (as the reference's sparse files).
    """
    p = params or GraspGenParams()
    if n <= 0:
        raise ValueError("n must be positive")
    start = time.perf_counter()
    rng = np.random.default_rng(seed)
    rays = RayCaster(mesh)
    collision = GripperCollision(mesh)
    normals = ContactNormals(mesh, p.contact_patch_radius)
    per_round = p.pairs_per_round or max(10 * n, 5000)
    kept_rows: list[np.ndarray] = []
    kept_contacts: list[np.ndarray] = []
    kept_normals: list[np.ndarray] = []
    stats: dict[str, Any] = {
        "pairs_sampled": 0,
        "pairs_valid": 0,
        "candidates": 0,
        "checked": 0,
        "rounds": 0,
    }
    for _ in range(p.max_rounds):
        if len(kept_rows) >= n:
            break
        stats["rounds"] += 1
        pairs = _sample_pairs(mesh, rays, normals, per_round, rng, p)
        stats["pairs_sampled"] += per_round
        stats["pairs_valid"] += len(pairs["score"])
        pair_order = np.lexsort((rng.random(len(pairs["score"])), pairs["score"]))
        pairs = {key: value[pair_order] for key, value in pairs.items()}
        for first in range(0, len(pairs["score"]), p.batch_pairs):
            if len(kept_rows) >= n:
                break
            batch = {key: value[first : first + p.batch_pairs] for key, value in pairs.items()}
            cand = _approach_candidates(batch, rays, rng, p)
            stats["candidates"] += len(cand["score"])
            # pair by pair (already in score order), approaches in random order
            order = np.lexsort((rng.random(len(cand["pair"])), cand["pair"]))
            rows = _rows(batch, cand, p)[order]
            pair_of_row = cand["pair"][order]
            inner = 0.5 * batch["distance"][pair_of_row] + p.contact_tolerance
            per_pair = np.zeros(len(batch["score"]), dtype=np.int64)
            for i in range(len(rows)):
                j = pair_of_row[i]
                if per_pair[j] >= p.grasps_per_pair:
                    continue
                stats["checked"] += 1
                boxes = grasp_boxes(rows[i], p.gripper, inner[i])
                if any(collision.box_hits(*box) for box in boxes):
                    continue
                if rays.inside(np.array([centre for _, centre, _ in boxes])).any():
                    continue
                per_pair[j] += 1
                kept_rows.append(rows[i])
                kept_contacts.append(np.stack([batch["c1"][j], batch["c2"][j]]))
                kept_normals.append(np.stack([batch["n1"][j], batch["n2"][j]]))
                if len(kept_rows) >= n:
                    break
    if kept_rows:
        rows_arr = np.asarray(kept_rows)
        order = np.argsort(rows_arr[:, 0], kind="stable")
        grasps = rows_arr[order].astype(np.float32)
        contacts = np.asarray(kept_contacts)[order]
        contact_normals = np.asarray(kept_normals)[order]
    else:
        grasps = np.zeros((0, 17), dtype=np.float32)
        contacts = contact_normals = np.zeros((0, 2, 3))
    stats["accepted"] = len(grasps)
    stats["seconds"] = time.perf_counter() - start
    return GraspAnnotations(grasps=grasps, contacts=contacts, normals=contact_normals, stats=stats)
