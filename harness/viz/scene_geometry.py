"""The scene's geometry in a Rerun recording: every visible collision geom of a MuJoCo model,
logged once in its body frame under ``/world/bodies/<body>`` (rerun-sdk 0.41).

The bodies are then posed by transforms on the ``sim_time`` timeline (``harness.viz.recording``).
Quaternions are wxyz inside the harness; Rerun wants xyzw, converted here and nowhere else.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from harness.transforms import quat_to_matrix, wxyz_to_xyzw

GEOM_COLORS = {
    "robot": (200, 200, 210),
    "pad": (40, 40, 40),
    "object": (230, 170, 40),
    "table": (150, 110, 80),
    "other": (180, 180, 180),
}


def rerun_sdk():
    """The ``rerun`` module, imported only when a recording is written."""
    import rerun as rr

    return rr


def _geom_kind(model: Any, geom_id: int) -> str:
    import mujoco

    name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, geom_id) or ""
    body = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, model.geom_bodyid[geom_id]) or ""
    if "pad" in name:
        return "pad"
    if body.startswith("robot"):
        return "robot"
    if "table" in name or "table" in body:
        return "table"
    if model.geom_bodyid[geom_id] != 0 and model.body_jntnum[model.geom_bodyid[geom_id]] > 0:
        return "object"
    return "other"


def body_entity(model: Any, body_id: int, root: str = "/world") -> str:
    import mujoco

    name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body_id) or f"body{body_id}"
    return f"{root}/bodies/{name.replace('/', '_')}"


def log_model_geometry(rec: Any, model: Any, root: str = "/world") -> list[int]:
    """Log every collision geom (group 0-2) statically in its body frame; returns body ids used."""
    bodies: dict[int, list[int]] = {}
    for geom_id in range(model.ngeom):
        if model.geom_group[geom_id] > 2 or model.geom_rgba[geom_id, 3] == 0:
            continue
        bodies.setdefault(int(model.geom_bodyid[geom_id]), []).append(geom_id)
    for body_id, geoms in bodies.items():
        entity = body_entity(model, body_id, root)
        for geom_id in geoms:
            archetype = _geom_archetype(model, geom_id)
            if archetype is None:
                continue
            rec.log(f"{entity}/geom{geom_id}", archetype, static=True)
    return sorted(bodies)


def _geom_archetype(model: Any, geom_id: int) -> Any:
    """The Rerun archetype drawing one geom in its body frame; None for unsupported types."""
    import mujoco

    rr = rerun_sdk()
    kind = _geom_kind(model, geom_id)
    color = GEOM_COLORS[kind]
    pos = model.geom_pos[geom_id]
    quat_xyzw = wxyz_to_xyzw(model.geom_quat[geom_id])
    size = model.geom_size[geom_id]
    gtype = model.geom_type[geom_id]
    if gtype == mujoco.mjtGeom.mjGEOM_BOX:
        return rr.Boxes3D(
            half_sizes=[size],
            centers=[pos],
            quaternions=[quat_xyzw],
            colors=[color],
            fill_mode="solid",
        )
    if gtype == mujoco.mjtGeom.mjGEOM_SPHERE:
        return rr.Ellipsoids3D(
            half_sizes=[[size[0]] * 3], centers=[pos], colors=[color], fill_mode="solid"
        )
    if gtype == mujoco.mjtGeom.mjGEOM_ELLIPSOID:
        return rr.Ellipsoids3D(
            half_sizes=[size],
            centers=[pos],
            quaternions=[quat_xyzw],
            colors=[color],
            fill_mode="solid",
        )
    if gtype == mujoco.mjtGeom.mjGEOM_CAPSULE:
        R = quat_to_matrix(model.geom_quat[geom_id])
        start = pos - R[:, 2] * size[1]
        return rr.Capsules3D(
            lengths=[2 * size[1]],
            radii=[size[0]],
            translations=[start],
            quaternions=[quat_xyzw],
            colors=[color],
        )
    if gtype == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return rr.Cylinders3D(
            lengths=[2 * size[1]],
            radii=[size[0]],
            centers=[pos],
            quaternions=[quat_xyzw],
            colors=[color],
            fill_mode="solid",
        )
    if gtype == mujoco.mjtGeom.mjGEOM_MESH:
        return _mesh_archetype(model, geom_id, pos, color)
    if gtype == mujoco.mjtGeom.mjGEOM_PLANE:
        extent = size[:2] if np.all(size[:2] > 0) else np.array([1.0, 1.0])
        return rr.Boxes3D(
            half_sizes=[[extent[0], extent[1], 1e-4]],
            centers=[pos],
            colors=[color],
            fill_mode="solid",
        )
    return None


def _mesh_archetype(model: Any, geom_id: int, pos: np.ndarray, color: tuple[int, int, int]) -> Any:
    """A mesh geom as a Mesh3D, its vertices moved into the body frame."""
    rr = rerun_sdk()
    mesh_id = model.geom_dataid[geom_id]
    v0, nv = model.mesh_vertadr[mesh_id], model.mesh_vertnum[mesh_id]
    f0, nf = model.mesh_faceadr[mesh_id], model.mesh_facenum[mesh_id]
    R = quat_to_matrix(model.geom_quat[geom_id])
    vertices = model.mesh_vert[v0 : v0 + nv] @ R.T + pos
    return rr.Mesh3D(
        vertex_positions=vertices,
        triangle_indices=model.mesh_face[f0 : f0 + nf],
        albedo_factor=[*color, 255],
    )
