"""An MP4 of one episode, rendered offscreen with MuJoCo from its recorded trace.

The trace keeps the full ``qpos`` every servo chunk (~10 ms of simulated time) and the robot's
root pose; replaying those with ``mj_kinematics`` reproduces every frame without stepping the
physics again. Frames are resampled to a fixed rate and written with imageio's ffmpeg plugin
(the ffmpeg binary ships inside the imageio-ffmpeg wheel, nothing is downloaded).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from harness.errors import HarnessError
from harness.viz.render import use_offscreen_gl

FPS = 30
WIDTH, HEIGHT = 640, 480


def frame_indices(trace_time: np.ndarray, fps: int = FPS) -> np.ndarray:
    """Indices into the trace, one per video frame (the last trace row at or before each frame)."""
    if len(trace_time) == 0:
        return np.zeros(0, dtype=int)
    times = np.arange(trace_time[0], trace_time[-1] + 1e-9, 1.0 / fps)
    return np.clip(np.searchsorted(trace_time, times, side="right") - 1, 0, len(trace_time) - 1)


def _camera(mujoco: Any, look_at: np.ndarray) -> Any:
    camera = mujoco.MjvCamera()
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    camera.lookat[:] = look_at
    camera.distance = 1.5
    camera.azimuth = 140.0
    camera.elevation = -28.0
    return camera


def write_episode_video(
    result: Any, path: Path, fps: int = FPS, width: int = WIDTH, height: int = HEIGHT
) -> int:
    """Write ``path`` (MP4) for an ``EpisodeResult`` with a trace; returns the frame count."""
    use_offscreen_gl()
    import imageio.v2 as imageio
    import mujoco

    trace, model = result.trace, result.model
    if trace is None or model is None:
        raise HarnessError("this episode stopped before its scene was built: nothing to film")
    data = mujoco.MjData(model)
    data.mocap_pos[:] = trace.mocap_pos
    data.mocap_quat[:] = trace.mocap_quat
    if len(trace.time):
        qposes = [trace.qpos[i] for i in frame_indices(np.asarray(trace.time), fps)]
    else:  # stopped before executing (no feasible plan): the scene as it was posed, 1 s
        qposes = [result.scene.data.qpos.copy()] * fps
    # Between the object and the robots (which stand at -y, facing +y), a little above the table.
    look_at = np.asarray(trace.T_world_object_start)[:3, 3] + [0.0, -0.2, 0.15]
    camera = _camera(mujoco, look_at)
    path.parent.mkdir(parents=True, exist_ok=True)
    headlight = model.vis.headlight
    saved = (headlight.ambient.copy(), headlight.diffuse.copy())
    headlight.ambient[:], headlight.diffuse[:] = 0.45, 0.6  # the scene's own light is dim
    try:
        _write(mujoco, imageio, model, data, camera, qposes, path, fps, (width, height))
    finally:
        headlight.ambient[:], headlight.diffuse[:] = saved
    return len(qposes)


def _write(
    mujoco: Any,
    imageio: Any,
    model: Any,
    data: Any,
    camera: Any,
    qposes: list[np.ndarray],
    path: Path,
    fps: int,
    size: tuple[int, int],
) -> None:
    width, height = size
    with (
        mujoco.Renderer(model, height, width) as renderer,
        imageio.get_writer(path, fps=fps, codec="libx264", macro_block_size=16) as writer,
    ):
        for qpos in qposes:
            data.qpos[:] = qpos
            mujoco.mj_kinematics(model, data)
            renderer.update_scene(data, camera)
            writer.append_data(renderer.render())
