"""Rerun recordings of episodes (rerun-sdk 0.41); the sweep's is in ``harness.viz.sweep_recording``.

Per episode: the scene geometry read from the MuJoCo model (one entity per body, animated by
replaying the recorded ``qpos`` through forward kinematics), every grasp candidate as an arrow
along its approach axis coloured by verdict, the planned and executed TCP paths, joint positions,
gripper width, finger forces and object height on a ``sim_time`` timeline, phase events as a text
log, and the verdict.

Quaternions are wxyz inside the harness; Rerun wants xyzw, converted here and nowhere else.
Logged transforms are float32 in Rerun, so read-back checks must not expect 1e-9 agreement.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from harness.files import WRITE_TIMEOUT_S, bounded, write_atomic
from harness.robots import RobotModel
from harness.transforms import quat_to_matrix, wxyz_to_xyzw

APP_ID = "pick-harness"

# Candidate verdict -> RGB. Chosen is drawn on top, thicker.
VERDICT_COLORS: dict[str, tuple[int, int, int]] = {
    "rejected": (150, 150, 150),
    "passed": (70, 130, 230),
    "infeasible": (230, 140, 40),
    "feasible": (60, 190, 90),
    "chosen": (220, 30, 200),
}
GEOM_COLORS = {
    "robot": (200, 200, 210),
    "pad": (40, 40, 40),
    "object": (230, 170, 40),
    "table": (150, 110, 80),
    "other": (180, 180, 180),
}


def _rr():
    import rerun as rr

    return rr


def new_recording(path: Path, name: str):
    """A RecordingStream writing to ``path`` (parents created)."""
    rr = _rr()
    path.parent.mkdir(parents=True, exist_ok=True)
    rec = rr.RecordingStream(APP_ID, recording_id=name)
    rec.save(str(path))
    return rec


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


# --------------------------------------------------------------------------------------------
# Scene geometry from a MuJoCo model


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

    rr = _rr()
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
    rr = _rr()
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


def episode_blueprint():
    import rerun.blueprint as rrb

    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial3DView(name="scene", origin="/world"),
            rrb.Vertical(
                rrb.TimeSeriesView(name="object height", origin="/plots/object_z"),
                rrb.TimeSeriesView(name="finger forces", origin="/plots/finger_force"),
                rrb.TimeSeriesView(name="gripper width", origin="/plots/gripper_width"),
                rrb.TimeSeriesView(name="validity: slip", origin="/plots/validity_slip"),
                rrb.TimeSeriesView(name="joints", origin="/plots/joints"),
                rrb.TextLogView(name="events", origin="/events"),
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


def _candidate_arrows(trace: Any, approach_index: int, tcp_offset: float) -> dict[str, tuple]:
    """Per verdict: arrow origins (EE origins) and vectors (to the TCP along the approach)."""
    groups: dict[str, tuple[list, list, list]] = {}
    for T, status, index in zip(
        trace.candidate_T_world_ee, trace.candidate_status, trace.candidate_index, strict=True
    ):
        origins, vectors, labels = groups.setdefault(str(status), ([], [], []))
        origins.append(T[:3, 3])
        vectors.append(T[:3, approach_index] * tcp_offset)
        labels.append(str(int(index)))
    return groups


def record_episode(result: Any, path: Path, task: Any) -> Path:
    """Write one episode's recording (``EpisodeResult`` with a trace and its scene's model)."""
    import mujoco

    rr = _rr()
    trace = result.trace
    model = result.model
    if trace is None or model is None:
        raise ValueError("the episode has no trace to record (it stopped before the scene ran)")
    row = result.row
    rec, stream = open_recording(str(row.get("episode_id") or Path(path).stem))
    rec.send_blueprint(episode_blueprint())
    rec.log("/world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)

    body_ids = log_model_geometry(rec, model)
    data = mujoco.MjData(model)
    if model.nmocap:
        data.mocap_pos[:] = trace.mocap_pos
        data.mocap_quat[:] = trace.mocap_quat
    frames = _frame_indices(np.asarray(trace.time))
    _log_body_motion_with_mocap(rec, model, data, trace.time[frames], trace.qpos[frames], body_ids)
    _log_candidates(rec, trace, task)
    _log_tcp_paths(rec, trace, frames)

    times = np.asarray(trace.time, dtype=float)
    _log_plots(rec, trace, times)
    _log_validity(rec, trace)
    for t, text in trace.events:
        rec.set_time("sim_time", duration=float(t))
        rec.log("/events", rr.TextLog(text, level=rr.TextLogLevel.INFO))
    _log_verdict(rec, row, times)
    return save_recording(rec, stream, Path(path))


def _log_candidates(rec: Any, trace: Any, task: Any) -> None:
    """Every grasp candidate as an arrow along its approach axis, one entity per verdict."""
    rr = _rr()
    robot = RobotModel.load(task.robot)
    convention = robot.convention
    tcp_offset = task.pick.tcp_offset or convention.tcp_offset
    for status, (origins, vectors, labels) in _candidate_arrows(
        trace, convention.approach_index, tcp_offset
    ).items():
        color = VERDICT_COLORS.get(status, (255, 255, 255))
        radius = 0.004 if status == "chosen" else 0.0015
        rec.log(
            f"/world/candidates/{status}",
            rr.Arrows3D(
                origins=origins,
                vectors=vectors,
                colors=[color] * len(origins),
                radii=[radius] * len(origins),
                labels=labels if status == "chosen" else None,
            ),
            static=True,
        )


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


def _log_verdict(rec: Any, row: dict[str, Any], times: np.ndarray) -> None:
    """The verdict as the last event at the episode's end, and as a text document."""
    rr = _rr()
    verdict = "SUCCESS" if row.get("success") else f"FAILURE: {row.get('failure_reason', '')}"
    end = float(times[-1]) if len(times) else 0.0
    rec.set_time("sim_time", duration=end)
    level = rr.TextLogLevel.INFO if row.get("success") else rr.TextLogLevel.ERROR
    rec.log("/events", rr.TextLog(f"verdict: {verdict}", level=level))
    rec.log(
        "/verdict",
        rr.TextDocument(_verdict_markdown(row, verdict), media_type="text/markdown"),
        static=True,
    )


def _log_body_motion_with_mocap(
    rec: Any, model: Any, data: Any, times: np.ndarray, qpos: np.ndarray, body_ids: list[int]
) -> None:
    import mujoco

    rr = _rr()
    positions = np.zeros((len(times), len(body_ids), 3))
    quats = np.zeros((len(times), len(body_ids), 4))
    for k, q in enumerate(qpos):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        positions[k] = data.xpos[body_ids]
        quats[k] = data.xquat[body_ids]
    index = [rr.TimeColumn("sim_time", duration=np.asarray(times, dtype=float))]
    for j, body_id in enumerate(body_ids):
        if body_id == 0:
            continue
        rec.send_columns(
            body_entity(model, body_id),
            indexes=index,
            columns=rr.Transform3D.columns(
                translation=positions[:, j], quaternion=wxyz_to_xyzw(quats[:, j])
            ),
        )


def _verdict_markdown(row: dict[str, Any], verdict: str) -> str:
    keys = (
        "robot",
        "arm",
        "object",
        "seed",
        "semantics",
        "test_mode",
        "timing",
        "n_total",
        "n_passed_filter",
        "n_feasible",
        "chosen_index",
        "chosen_score",
        "approach_angle_deg",
        "lift_height_m",
        "finger_force_left_n",
        "finger_force_right_n",
        "slip_m",
        "tcp_grasp_error_m",
        "valid",
        "invalid_reason",
        "robustness_g",
        "hold_slip_m",
        "min_finger_force_n",
        "table_penetration_m",
        "error_message",
    )
    lines = [f"# {verdict}", "", "| key | value |", "|---|---|"]
    for key in keys:
        if key in row and row[key] not in ("", None):
            value = row[key]
            lines.append(
                f"| {key} | {value:.4g} |" if isinstance(value, float) else f"| {key} | {value} |"
            )
    return "\n".join(lines)
