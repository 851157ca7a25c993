"""A picture of an object for ``harness objects show --render FILE.png``: three offscreen MuJoCo
views side by side, the mesh, its convex collision pieces, and a sample of its grasps as gripper
boxes (coloured by score, green = 0.1).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from harness.grasps.grasp_set import read_grasp_array
from harness.objects.assets import ObjectAsset
from harness.objects.graspgen import GripperModel, grasp_boxes
from harness.viz.render import render_views, use_offscreen_gl
from harness.writes import write_through

PIECE_PALETTE = np.array(
    [[0.9, 0.4, 0.3], [0.3, 0.6, 0.9], [0.4, 0.8, 0.4], [0.9, 0.8, 0.3], [0.7, 0.4, 0.9]]
)


def _score_colour(score: float) -> list[float]:
    """Green for 0.1 through yellow to red for 1.0."""
    t = float(np.clip((score - 0.1) / 0.9, 0.0, 1.0))
    return [min(1.0, 2 * t), min(1.0, 2 * (1 - t)), 0.1, 1.0]


def render_object(
    asset: ObjectAsset,
    out: Path,
    n_grasps: int = 8,
    size: tuple[int, int] = (400, 480),
    seed: int = 0,
) -> Path:
    """Offscreen MuJoCo render: mesh | collision pieces | sampled grasps, saved as one PNG."""
    use_offscreen_gl()
    import mujoco
    from PIL import Image, ImageDraw

    spec = _object_spec(size)
    _add_mesh(spec, "object", asset.vertices, asset.faces, [0.75, 0.72, 0.65, 1.0], 0)
    for i, (vertices, faces) in enumerate(asset.collision_pieces):
        _add_mesh(
            spec, f"piece{i}", vertices, faces, [*PIECE_PALETTE[i % len(PIECE_PALETTE)], 1.0], 1
        )
    _add_mesh(spec, "ghost", asset.vertices, asset.faces, [0.75, 0.72, 0.65, 0.45], 2)
    shown = _add_grasps(spec, asset, n_grasps, seed)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    camera = _object_camera(asset)
    titles = [
        f"{asset.path.name}: {len(asset.vertices)} vertices",
        f"collision: {len(asset.collision_pieces)} convex pieces",
        f"{shown} random grasps (green = score 0.1, red = 1.0)" if shown else "no grasp file",
    ]
    panels = render_views(model, data, camera, size[1], size[0], ((0,), (1,), (2, 3)))
    image = Image.fromarray(np.concatenate(panels, axis=1))
    draw = ImageDraw.Draw(image)
    for i, title in enumerate(titles):
        draw.text((i * size[1] + 8, 6), title, fill=(20, 20, 20))
    write_through(out, image.save)
    return out


def _object_spec(size: tuple[int, int]) -> Any:
    """An empty scene: offscreen buffer of ``size`` (height, width), a sky and one light."""
    import mujoco

    spec = mujoco.MjSpec()
    spec.visual.global_.offwidth = size[1]
    spec.visual.global_.offheight = size[0]
    spec.visual.headlight.ambient = [0.35, 0.35, 0.35]
    spec.visual.headlight.diffuse = [0.55, 0.55, 0.55]
    sky = spec.add_texture()
    sky.name = "sky"
    sky.type = mujoco.mjtTexture.mjTEXTURE_SKYBOX
    sky.builtin = mujoco.mjtBuiltin.mjBUILTIN_GRADIENT
    sky.rgb1, sky.rgb2 = [1.0, 1.0, 1.0], [0.78, 0.8, 0.86]
    sky.width = sky.height = 64
    light = spec.worldbody.add_light()
    light.pos = [0.3, -0.3, 0.6]
    light.dir = [-0.4, 0.4, -1.0]
    return spec


def _add_mesh(
    spec: Any, name: str, vertices: np.ndarray, faces: np.ndarray, rgba: Any, group: int
) -> None:
    """A visual-only mesh geom in the world body, drawn in geom group ``group``."""
    import mujoco

    mesh = spec.add_mesh()
    mesh.name = name
    mesh.uservert = np.asarray(vertices, dtype=np.float32).ravel()
    mesh.userface = np.asarray(faces, dtype=np.int32).ravel()
    mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
    geom = spec.worldbody.add_geom()
    geom.type = mujoco.mjtGeom.mjGEOM_MESH
    geom.meshname = name
    geom.rgba = rgba
    geom.group = group
    geom.contype = geom.conaffinity = 0


def _add_grasps(spec: Any, asset: ObjectAsset, n_grasps: int, seed: int) -> int:
    """Up to ``n_grasps`` random grasps of the asset's grasp file as boxes; how many were drawn."""
    shown = 0
    if asset.grasp_path is not None:
        grasps = np.asarray(read_grasp_array(asset.grasp_path), dtype=np.float64)
        if grasps.ndim == 2 and grasps.shape[1] == 17 and len(grasps):
            rng = np.random.default_rng(seed)
            rows = grasps[np.sort(rng.choice(len(grasps), min(n_grasps, len(grasps)), False))]
            # thin GraspNet-style drawing: two fingers, a palm and a tail along -g_x
            thin = GripperModel(
                finger_thickness=0.002, height=0.004, palm_thickness=0.002, approach_clearance=0.0
            )
            for row in rows:
                _add_grasp_boxes(spec, row, thin)
                shown += 1
    return shown


def _add_grasp_boxes(spec: Any, row: np.ndarray, thin: GripperModel) -> None:
    """One grasp row as visual-only boxes in geom group 3, coloured by its score."""
    import mujoco

    boxes = grasp_boxes(row, thin, 0.5 * row[1])
    rotation = boxes[0][0]
    tail_centre = np.array([row[3] - thin.finger_length - 0.017, 0.0, 0.0])
    boxes.append(
        (
            rotation,
            row[13:16] + rotation @ tail_centre,
            np.array([0.03, 0.002, 0.004]),
        )
    )
    for rotation, centre, box_size in boxes:
        geom = spec.worldbody.add_geom()
        geom.type = mujoco.mjtGeom.mjGEOM_BOX
        geom.size = 0.5 * np.asarray(box_size)
        geom.pos = centre
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rotation).ravel())
        geom.quat = quat
        geom.rgba = _score_colour(row[0])
        geom.group = 3
        geom.contype = geom.conaffinity = 0


def _object_camera(asset: ObjectAsset) -> Any:
    """A camera looking at the asset's bounding-box centre from the front-left, above."""
    import mujoco

    lo, hi = asset.bounds
    camera = mujoco.MjvCamera()
    camera.lookat[:] = 0.5 * (lo + hi)
    camera.distance = 1.7 * float(np.linalg.norm(hi - lo)) + 0.12
    camera.azimuth, camera.elevation = 135.0, -28.0
    return camera
