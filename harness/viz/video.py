"""An MP4 of one episode, rendered offscreen with MuJoCo from its recorded trace, and its
poster: the frame that shows why (``harness.viz.cause``).

The trace keeps the full ``qpos`` every servo chunk (~10 ms of simulated time) and the robot's
root pose; replaying those with ``mj_kinematics`` reproduces every frame without stepping the
physics again. Frames are resampled to a fixed rate and written with imageio's ffmpeg plugin
(the ffmpeg binary ships inside the imageio-ffmpeg wheel, nothing is downloaded).

Every frame carries a caption band (robot, arm, object, seed; the outcome headline with both
verdicts, coloured green / orange / red for valid / invalid / failed) and the cause's label. The
video holds ``HOLD_S`` on the cause frame with the cause marked (a red sphere); an episode that
never moved (a planning failure) shows its reset pose briefly, then the configuration that
failed. For a finger through the table the table is drawn translucent, so the finger shows.
The poster (``<video>.png``) is that cause frame.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from harness.errors import HarnessError
from harness.viz.cause import Cause, find_cause
from harness.viz.headline import KIND_COLORS, caption, headline, outcome_kind
from harness.viz.render import use_offscreen_gl
from harness.writes import check_target, output_dir, write_through

FPS = 30
WIDTH, HEIGHT = 640, 480
HOLD_S = 1.5  # seconds the video rests on the cause frame
START_S = 0.5  # seconds of the reset pose before a configuration that was never executed
MARK_RADIUS_M = 0.018
CAUSE_DISTANCE_M = 0.6  # the camera closes in on the cause while the video holds on it
TABLE_ALPHA = 0.35  # the table's opacity when a finger went through it


def frame_indices(trace_time: np.ndarray, fps: int = FPS) -> np.ndarray:
    """Indices into the trace, one per video frame (the last trace row at or before each frame)."""
    if len(trace_time) == 0:
        return np.zeros(0, dtype=int)
    times = np.arange(trace_time[0], trace_time[-1] + 1e-9, 1.0 / fps)
    return np.clip(np.searchsorted(trace_time, times, side="right") - 1, 0, len(trace_time) - 1)


def _camera(mujoco: Any, look_at: np.ndarray, distance: float = 1.5) -> Any:
    camera = mujoco.MjvCamera()
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    camera.lookat[:] = look_at
    camera.distance = distance
    camera.azimuth = 140.0
    camera.elevation = -28.0
    return camera


def _frames(trace: Any, cause: Cause, fps: int) -> list[tuple[np.ndarray, bool]]:
    """(qpos, show the cause mark) per video frame."""
    hold = max(1, round(HOLD_S * fps))
    if not len(trace.time):
        start = trace.qpos_start if trace.qpos_start is not None else cause.qpos
        frames = [(np.asarray(start), False)] * max(1, round(START_S * fps))
        if cause.qpos is not None:
            frames += [(np.asarray(cause.qpos), True)] * hold
        return frames
    frames: list[tuple[np.ndarray, bool]] = []
    held = False
    for index in frame_indices(np.asarray(trace.time), fps):
        frames.append((trace.qpos[index], False))
        if not held and cause.row is not None and index >= cause.row:
            frames += [(trace.qpos[cause.row], True)] * hold
            held = True
    if not held:
        frames += [(trace.qpos[-1], True)] * hold
    return frames


def write_episode_video(
    result: Any,
    path: Path,
    fps: int = FPS,
    width: int = WIDTH,
    height: int = HEIGHT,
    root: Path | None = None,
) -> int:
    """Write ``path`` (MP4) and its poster ``path.with_suffix('.png')`` for an
    ``EpisodeResult`` with a trace; returns the frame count. Both go through
    ``harness.writes`` (``root``: the run directory, no symlink followed below it)."""
    use_offscreen_gl()
    import imageio.v2 as imageio
    import mujoco

    trace, model = result.trace, result.model
    if trace is None or model is None:
        raise HarnessError("this episode stopped before its scene was built: nothing to film")
    if trace.qpos_start is None and not len(trace.time):
        trace.qpos_start = result.scene.data.qpos.copy()
    row = result.row
    cause = find_cause(row, trace, model, getattr(result, "scene", None))
    data = mujoco.MjData(model)
    data.mocap_pos[:] = trace.mocap_pos
    data.mocap_quat[:] = trace.mocap_quat
    frames = _frames(trace, cause, fps)
    # Between the object and the robots (which stand at -y, facing +y), a little above the table.
    look_at = np.asarray(trace.T_world_object_start)[:3, 3] + [0.0, -0.2, 0.15]
    camera = _camera(mujoco, look_at)
    close = camera
    if cause.point is not None and outcome_kind(row) != "valid":
        close = _camera(mujoco, cause.point, CAUSE_DISTANCE_M)
    poster_path = path.with_suffix(".png")
    check_target(path)
    check_target(poster_path)
    output_dir(path.parent, root)
    overlay = Overlay(row, cause.label, width)
    table_alpha = TABLE_ALPHA if "through the table" in cause.label else None
    posters: list[np.ndarray] = []

    def encode(tmp: Path) -> None:
        with _Lit(model, table_alpha):
            posters.append(_write(
                mujoco, imageio, model, data, (camera, close), frames, cause, overlay, tmp, fps,
                (width, height),
            ))  # fmt: skip

    write_through(path, encode, root=root)
    write_through(poster_path, lambda tmp: imageio.imwrite(tmp, posters[0]), root=root)
    return len(frames)


class _Lit:
    """Brighter headlight (the scene's own light is dim) and, optionally, a translucent table,
    restored afterwards."""

    def __init__(self, model: Any, table_alpha: float | None) -> None:
        self.model, self.table_alpha = model, table_alpha

    def __enter__(self) -> None:
        import mujoco

        light = self.model.vis.headlight
        self.saved = (light.ambient.copy(), light.diffuse.copy())
        light.ambient[:], light.diffuse[:] = 0.45, 0.6
        self.table = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_GEOM, "table")
        self.rgba = self.model.geom_rgba[self.table].copy() if self.table >= 0 else None
        if self.table_alpha is not None and self.table >= 0:
            self.model.geom_rgba[self.table, 3] = self.table_alpha

    def __exit__(self, *exc: object) -> None:
        light = self.model.vis.headlight
        light.ambient[:], light.diffuse[:] = self.saved
        if self.rgba is not None:
            self.model.geom_rgba[self.table] = self.rgba


def _mark(mujoco: Any, scene: Any, point: np.ndarray) -> None:
    """A translucent red sphere at ``point`` in the rendered scene."""
    if scene.ngeom >= scene.maxgeom:
        return
    mujoco.mjv_initGeom(
        scene.geoms[scene.ngeom], mujoco.mjtGeom.mjGEOM_SPHERE, np.full(3, MARK_RADIUS_M),
        np.asarray(point, dtype=float), np.eye(3).ravel(), np.array([1.0, 0.1, 0.1, 0.6]),
    )  # fmt: skip
    scene.ngeom += 1


def project(cameras: Any, point: np.ndarray, width: int, height: int) -> tuple[float, float] | None:
    """Pixel (x, y) of a world point in a mono render of an ``mjvScene`` (None behind the
    camera). The scene keeps two eye cameras; a mono render uses their average."""
    camera = cameras[0]
    position, forward, up = (
        (np.asarray(getattr(cameras[0], name)) + np.asarray(getattr(cameras[1], name))) / 2.0
        for name in ("pos", "forward", "up")
    )
    right = np.cross(forward, up)
    offset = np.asarray(point, dtype=float) - position
    depth = float(offset @ forward)
    if depth <= 1e-6:
        return None
    x = float(offset @ right) / depth * camera.frustum_near
    y = float(offset @ up) / depth * camera.frustum_near
    # mjr_render sets the frustum's width from the viewport's aspect ratio.
    span = (camera.frustum_top - camera.frustum_bottom) * width / height
    left = camera.frustum_center - span / 2.0
    u = (x - left) / span * width
    v = (camera.frustum_top - y) / (camera.frustum_top - camera.frustum_bottom) * height
    return u, v


def _write(
    mujoco: Any,
    imageio: Any,
    model: Any,
    data: Any,
    cameras: tuple[Any, Any],
    frames: list[tuple[np.ndarray, bool]],
    cause: Cause,
    overlay: Overlay,
    tmp: Path,
    fps: int,
    size: tuple[int, int],
) -> np.ndarray:
    """Render and encode the frames (the marked ones from the close camera) into ``tmp`` (the
    temp file of ``write_through``); returns the poster (the first marked frame)."""
    width, height = size
    poster: np.ndarray | None = None
    with (
        mujoco.Renderer(model, height, width) as renderer,
        imageio.get_writer(tmp, fps=fps, codec="libx264", macro_block_size=16) as writer,
    ):
        for qpos, marked in frames:
            data.qpos[:] = qpos
            mujoco.mj_kinematics(model, data)
            renderer.update_scene(data, cameras[1] if marked else cameras[0])
            ring = None
            if marked and cause.point is not None:
                _mark(mujoco, renderer.scene, cause.point)
                ring = project(renderer.scene.camera, cause.point, width, height)
            image = overlay.draw(renderer.render(), marked, ring)
            if marked and poster is None:
                poster = image
            writer.append_data(image)
    return poster if poster is not None else image


class Overlay:
    """The caption band on top (what, and the headline in its outcome's colour) and the cause's
    label at the bottom (bold while the video holds on the cause)."""

    def __init__(self, row: Any, cause_label: str, width: int) -> None:
        from PIL import ImageFont

        self.caption = caption(row)
        self.headline = headline(row)
        self.cause = cause_label
        self.color = KIND_COLORS[outcome_kind(row)]
        size = max(9, round(width / 40))  # 16 px at 640 wide
        self.font = ImageFont.load_default(size=size)
        self.size = size

    def _fit(self, text: str, room: int) -> Any:
        """The band's font, smaller until ``text`` fits in ``room`` pixels (7 px at least)."""
        from PIL import ImageFont

        size, font = self.size, self.font
        while size > 7 and font.getlength(text) > room:
            size -= 1
            font = ImageFont.load_default(size=size)
        return font

    def draw(
        self, image: np.ndarray, marked: bool, ring: tuple[float, float] | None = None
    ) -> np.ndarray:
        from PIL import Image, ImageDraw

        picture = Image.fromarray(image)
        draw = ImageDraw.Draw(picture, "RGBA")
        width, height = picture.size
        line = self.size + 4
        draw.rectangle((0, 0, width, 2 * line + 4), fill=(20, 22, 26, 210))
        if ring is not None:  # the cause's place, visible even behind the robot
            radius = max(8, width // 40)
            x, y = ring
            box = (x - radius, y - radius, x + radius, y + radius)
            draw.ellipse(box, outline=(255, 40, 40), width=max(2, width // 200))
        room = width - 12
        draw.text((6, 3), self.caption, fill=(235, 235, 235), font=self._fit(self.caption, room))
        draw.text(
            (6, 3 + line), self.headline, fill=self.color, font=self._fit(self.headline, room)
        )
        if self.cause:
            draw.rectangle(
                (0, height - line - 6, width, height), fill=(20, 22, 26, 200 if marked else 140)
            )
            fill = (255, 90, 90) if marked else (220, 220, 220)
            font = self._fit(self.cause, width - 12)
            draw.text((6, height - line - 3), self.cause, fill=fill, font=font)
        return np.asarray(picture)
