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

import time
from typing import Any

import numpy as np
import trimesh

from harness.objects.graspgen.collision import GripperCollision, grasp_boxes
from harness.objects.graspgen.contacts import (
    ContactNormals,
    RayCaster,
    force_closure_score,
    perpendicular_basis,
    sample_surface,
)
from harness.objects.graspgen.model import (
    OBJECT_ID,
    RAY_EPSILON,
    GraspAnnotations,
    GraspGenParams,
)


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
    a, b = perpendicular_basis(-n1)
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
    a, b = perpendicular_basis(pairs["axis"])
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
