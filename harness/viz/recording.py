"""Rerun recordings of episodes (rerun-sdk 0.41); the sweep's is in ``harness.viz.sweep_recording``.

Per episode: the scene geometry read from the MuJoCo model (``harness.viz.scene_geometry``; one
entity per body, posed by replaying the recorded ``qpos`` through forward kinematics, or at its
reset state when nothing was executed), every grasp candidate as an arrow coloured by verdict
with the tested ones' reasons as labels, the pre-grasp and grasp targets, the finger-object
contacts and forces (``harness.viz.episode_layers``), the planned and executed TCP paths, joint
positions, gripper width, finger forces and object height on a ``sim_time`` timeline, phase
events as a text log, and the verdict with its failure message as a document the blueprint
shows.

Quaternions are wxyz inside the harness; Rerun wants xyzw, converted here and nowhere else.
Logged transforms are float32 in Rerun, so read-back checks must not expect 1e-9 agreement.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from harness.files import WRITE_TIMEOUT_S, bounded, write_atomic
from harness.robots import RobotModel
from harness.transforms import wxyz_to_xyzw
from harness.viz.cause import find_cause
from harness.viz.episode_layers import (
    FAILURE_POSE_TIME_S,
    VERDICT_COLORS,
    log_candidates,
    log_cause,
    log_contacts,
    log_targets,
    log_verdict,
)
from harness.viz.label_layout import LabelLayout
from harness.viz.scene_geometry import body_entity, log_model_geometry
from harness.viz.scene_geometry import rerun_sdk as _rr

APP_ID = "pick-harness"
__all__ = [
    "APP_ID",
    "VERDICT_COLORS",
    "episode_blueprint",
    "open_recording",
    "record_episode",
    "save_recording",
]


def open_recording(name: str) -> tuple[Any, Any]:
    """A RecordingStream logging into memory, and its byte stream (see ``save_recording``)."""
    rr = _rr()
    rec = rr.RecordingStream(APP_ID, recording_id=name)
    return rec, rec.binary_stream()


def save_recording(rec: Any, stream: Any, path: Path) -> Path:
    """Write an ``open_recording`` to ``path`` whole or not at all (temp file + rename, bounded
    waits): a full or hung disk raises instead of hanging the run or leaving a truncated
    ``.rrd`` (rerun's own file sink can block in ``disconnect()`` on a full disk)."""
    data = bounded(lambda: stream.read(flush=True) or b"", WRITE_TIMEOUT_S, "flushing a recording")
    bounded(rec.disconnect, WRITE_TIMEOUT_S, "closing a recording")
    return write_atomic(path, data)


def log_series(
    rec: Any, path: str, times: np.ndarray, values: np.ndarray, names: list[str]
) -> None:
    """A (T,) or (T, k) series as Scalars on the sim_time timeline, with named lines."""
    rr = _rr()
    values = np.asarray(values, dtype=float)
    if values.ndim == 1:
        values = values[:, None]
    rec.log(path, rr.SeriesLines(names=names), static=True)
    rec.send_columns(
        path,
        indexes=[rr.TimeColumn("sim_time", duration=np.asarray(times, dtype=float))],
        columns=rr.Scalars.columns(scalars=values),
    )


def episode_blueprint(executed: bool = True):
    """The viewer layout: the 3D scene above the verdict document, the plots and events beside;
    an episode that stopped before moving has no series, so its verdict takes their place."""
    import rerun.blueprint as rrb

    scene = rrb.Spatial3DView(name="scene", origin="/world")
    verdict = rrb.TextDocumentView(name="verdict", origin="/verdict")
    events = rrb.TextLogView(name="events", origin="/events")
    if not executed:
        return rrb.Blueprint(
            rrb.Horizontal(scene, rrb.Vertical(verdict, events, row_shares=[4, 1])),
            collapse_panels=True,
        )
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(scene, verdict, row_shares=[3, 2]),
            rrb.Vertical(
                rrb.TimeSeriesView(name="object height", origin="/plots/object_z"),
                rrb.TimeSeriesView(name="finger forces", origin="/plots/finger_force"),
                rrb.TimeSeriesView(name="gripper width", origin="/plots/gripper_width"),
                rrb.TimeSeriesView(name="validity: slip", origin="/plots/validity_slip"),
                rrb.TimeSeriesView(name="joints", origin="/plots/joints"),
                events,
            ),
            column_shares=[3, 2],
        ),
        collapse_panels=True,
    )


# --------------------------------------------------------------------------------------------
# Episodes

MAX_FRAME_RATE = 30.0  # Hz of logged body transforms; physics runs at 500 Hz


def _frame_indices(times: np.ndarray, rate: float = MAX_FRAME_RATE) -> np.ndarray:
    """Indices of trace samples spaced at least 1/rate apart (always keeping the last)."""
    if len(times) == 0:
        return np.zeros(0, dtype=int)
    keep = [0]
    for index in range(1, len(times)):
        if times[index] - times[keep[-1]] >= 1.0 / rate:
            keep.append(index)
    if keep[-1] != len(times) - 1:
        keep.append(len(times) - 1)
    return np.asarray(keep, dtype=int)


def record_episode(result: Any, path: Path, task: Any) -> Path:
    """Write one episode's recording (``EpisodeResult`` with a trace and its scene's model).

    Whatever the outcome, the scene is posed: an episode that stopped before execution (no
    candidate, none feasible, no plan) shows its reset state at ``sim_time`` 0 and, when a
    planned configuration failed, that configuration at ``FAILURE_POSE_TIME_S`` (where the
    viewer opens). The cause (``harness.viz.cause``) is marked at ``/world/cause``."""
    rr = _rr()
    trace = result.trace
    model = result.model
    if trace is None or model is None:
        raise ValueError("the episode has no trace to record (it stopped before the scene ran)")
    row = result.row
    rec, stream = open_recording(str(row.get("episode_id") or Path(path).stem))
    rec.send_blueprint(episode_blueprint(executed=len(trace.time) > 0))
    rec.log("/world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)

    times = np.asarray(trace.time, dtype=float)
    frames = _frame_indices(times)
    _log_scene(rec, model, trace, frames)
    cause = find_cause(row, trace, model, getattr(result, "scene", None))
    layout = LabelLayout()  # the cause's label first, then the chosen targets', then candidates'
    log_cause(
        rec, cause, float(times[cause.row]) if cause.row is not None and len(times) else None,
        layout,
    )  # fmt: skip
    convention = RobotModel.load(task.robot).convention
    tcp_offset = task.pick.tcp_offset or convention.tcp_offset
    log_targets(rec, trace, convention.approach_index, tcp_offset, layout)
    log_candidates(rec, trace, convention.approach_index, tcp_offset, layout)
    _log_tcp_paths(rec, trace, frames)
    log_contacts(rec, trace)
    _log_plots(rec, trace, times)
    _log_validity(rec, trace)
    for t, text in trace.events:
        rec.set_time("sim_time", duration=float(t))
        rec.log("/events", rr.TextLog(text, level=rr.TextLogLevel.INFO))
    end = (
        float(times[-1])
        if len(times)
        else (FAILURE_POSE_TIME_S if trace.failure_qpos is not None else 0.0)
    )
    log_verdict(rec, row, trace, end, cause.label)
    return save_recording(rec, stream, Path(path))


def _log_scene(rec: Any, model: Any, trace: Any, frames: np.ndarray) -> None:
    """The geometry, posed at every logged frame of the execution, or at t = 0 in the state
    before any motion when nothing was executed."""
    import mujoco

    body_ids = log_model_geometry(rec, model)
    data = mujoco.MjData(model)
    if model.nmocap:
        data.mocap_pos[:] = trace.mocap_pos
        data.mocap_quat[:] = trace.mocap_quat
    if len(frames):
        times, qpos = np.asarray(trace.time)[frames], np.asarray(trace.qpos)[frames]
    elif trace.qpos_start is not None:
        times, qpos = np.zeros(1), np.asarray(trace.qpos_start)[None, :]
        if trace.failure_qpos is not None:  # then the configuration that failed planning
            times = np.array([0.0, FAILURE_POSE_TIME_S])
            qpos = np.stack([trace.qpos_start, trace.failure_qpos])
    else:
        return
    _log_body_motion_with_mocap(rec, model, data, times, qpos, body_ids)


def _log_tcp_paths(rec: Any, trace: Any, frames: np.ndarray) -> None:
    """The planned and the executed TCP paths, and the executed TCP at each logged frame."""
    rr = _rr()
    if len(trace.planned_tcp):
        rec.log(
            "/world/plan/tcp",
            rr.LineStrips3D([trace.planned_tcp], colors=[(60, 200, 255)], radii=[0.002]),
            static=True,
        )
    tcp = np.asarray(trace.tcp_pose)[:, :3]
    if len(tcp):
        rec.log(
            "/world/executed/tcp",
            rr.LineStrips3D([tcp], colors=[(255, 80, 80)], radii=[0.0015]),
            static=True,
        )
        rec.send_columns(
            "/world/executed/tcp_now",
            indexes=[rr.TimeColumn("sim_time", duration=trace.time[frames])],
            columns=rr.Points3D.columns(positions=tcp[frames]).partition([1] * len(frames)),
        )


def _log_plots(rec: Any, trace: Any, times: np.ndarray) -> None:
    """Object height, finger forces, gripper width and joint positions over sim_time."""
    if len(times):
        log_series(rec, "/plots/object_z", times, trace.object_pose[:, 2], ["object z (m)"])
        log_series(
            rec,
            "/plots/finger_force",
            times,
            trace.finger_forces,
            ["left finger (N)", "right finger (N)"],
        )
        log_series(rec, "/plots/gripper_width", times, trace.gripper_width, ["width (m)"])
        log_series(rec, "/plots/joints", times, trace.q, list(trace.joint_names))


TUG_ARROW_M_PER_G = 0.03  # length of a tug arrow per g of pull


def _log_validity(rec: Any, trace: Any) -> None:
    """The validity phase: the slip series, and each tug rung as an arrow at the object (green
    survived, red lost) for the rung's duration."""
    rr = _rr()
    validity = getattr(trace, "validity", None)
    if validity is None or not len(validity.time):
        return
    log_series(rec, "/plots/validity_slip", validity.time, validity.slip_m, ["slip (m)"])
    times = np.asarray(trace.time, dtype=float)
    for tug in validity.tugs:
        index = min(int(np.searchsorted(times, tug.t_start)), len(times) - 1)
        origin = trace.object_pose[index, :3]
        norm = float(np.linalg.norm(tug.force_n)) or 1.0
        vector = tug.force_n / norm * tug.level_g * TUG_ARROW_M_PER_G
        rec.set_time("sim_time", duration=float(tug.t_start))
        rec.log(
            "/world/validity/tug",
            rr.Arrows3D(
                origins=[origin],
                vectors=[vector],
                colors=[(60, 220, 90) if tug.survived else (240, 60, 60)],
                radii=[0.004],
                labels=[f"{tug.direction} {tug.level_g:g} g ({norm:.1f} N)"],
            ),
        )
        rec.set_time("sim_time", duration=float(tug.t_end))
        rec.log("/world/validity/tug", rr.Clear(recursive=False))


def _log_body_motion_with_mocap(
    rec: Any, model: Any, data: Any, times: np.ndarray, qpos: np.ndarray, body_ids: list[int]
) -> None:
    import mujoco

    """Each body's world pose at ``times`` from ``qpos`` by forward kinematics."""
    rr = _rr()
    positions = np.zeros((len(times), len(body_ids), 3))
    quats = np.zeros((len(times), len(body_ids), 4))
    for k, q in enumerate(qpos):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        positions[k] = data.xpos[body_ids]
        quats[k] = data.xquat[body_ids]
    index = [rr.TimeColumn("sim_time", duration=np.asarray(times, dtype=float))]
    for j, body_id in enumerate(body_ids):  # the world body too: an identity, still a pose
        rec.send_columns(
            body_entity(model, body_id),
            indexes=index,
            columns=rr.Transform3D.columns(
                translation=positions[:, j], quaternion=wxyz_to_xyzw(quats[:, j])
            ),
        )
