"""The per-servo-chunk record of one pick execution, for viewers and tests.

Preallocated buffers (``TraceRecorder``) filled once per servo chunk (~10 ms) by the executor,
trimmed into an ``ExecutionTrace`` at the end; kept apart from the control loop so the loop
reads as control and the record as data.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from harness.sim import Scene


@dataclass
class TugRecord:
    """One rung of the tug ladder: a force along one world direction for ``TUG_TIME_S``."""

    direction: str  # "+x", "-x", "+y", "-y", "+z", "-z"
    level_g: float  # k: the force is k x g x mass
    force_n: np.ndarray  # (3,) world force on the object's centre of mass (N)
    t_start: float  # s of execution time (the trace's clock)
    t_end: float
    slip_m: float  # object motion relative to the TCP since the end of the hold
    between_fingers: bool
    survived: bool


@dataclass
class ValidityTrace:
    """The validity phase for a viewer: the slip series (hold and tug) and the tug rungs."""

    time: np.ndarray  # (K,) s of execution time
    slip_m: np.ndarray  # (K,) object motion relative to the TCP since the hold started / ended
    stage: np.ndarray  # (K,) str: settle, hold, tug
    tugs: list[TugRecord] = field(default_factory=list)


CONTACT_SAMPLE_RATE_HZ = 30.0  # the recording's frame rate; the trace rows come at ~100 Hz


@dataclass
class FingerContacts:
    """Finger-object contacts sampled on some trace rows, flattened: contact ``k`` belongs to
    row ``row[k]``. ``sampled`` are the rows looked at: the first row of each touch, then rows
    at most ``CONTACT_SAMPLE_RATE_HZ`` apart while touching, and the row a touch ends (with no
    contacts), so a viewer knows when to clear them. Sampling keeps the trace cheap."""

    sampled: np.ndarray  # (S,) trace row indices, increasing
    row: np.ndarray  # (C,) trace row index of each contact (one of ``sampled``)
    position: np.ndarray  # (C, 3) world contact point
    force: np.ndarray  # (C, 3) N, world force on the object (normal and friction)
    finger: np.ndarray  # (C,) 0 left, 1 right

    @classmethod
    def empty(cls) -> FingerContacts:
        rows = np.zeros(0, dtype=np.int64)
        return cls(rows, rows.copy(), np.zeros((0, 3)), np.zeros((0, 3)), rows.copy())


@dataclass
class ExecutionTrace:
    """Per-servo-chunk (~10 ms) record of an execution (arrays trimmed to the rows recorded)."""

    time: np.ndarray  # (T,) s since the start of the execution
    qpos: np.ndarray  # (T, nq) full MuJoCo qpos
    q_active: np.ndarray  # (T, n) the arm's active joints
    tcp_pose: np.ndarray  # (T, 7) world position + wxyz quaternion of the TCP frame
    ee_pose: np.ndarray  # (T, 7) world pose of the EE frame
    gripper_width: np.ndarray  # (T,) m (sum of both fingers)
    finger_forces: np.ndarray  # (T, 2) N, left and right finger on the target object
    object_pose: np.ndarray  # (T, 7) world pose of the target object
    phase: np.ndarray  # (T,) str: the head command's function / target
    events: list[tuple[float, str]] = field(default_factory=list)
    validity: ValidityTrace | None = None  # the validity phase (its rows are in the arrays too)
    contacts: FingerContacts | None = None  # the finger-object contacts of every row


class TraceRecorder:
    """Preallocated per-step buffers; ``finish()`` trims them into an ExecutionTrace."""

    def __init__(self, scene: Scene, arm: str, object_name: str, capacity: int) -> None:
        self.scene = scene
        self.handles = scene.arms[arm]
        self.arm = arm
        self.object_name = object_name
        self.obj = scene.objects[object_name]
        n = capacity
        nq = scene.model.nq
        self.time = np.zeros(n)
        self.qpos = np.zeros((n, nq))
        self.q_active = np.zeros((n, len(self.handles.active_qpos)))
        self.tcp_pose = np.zeros((n, 7))
        self.ee_pose = np.zeros((n, 7))
        self.gripper_width = np.zeros(n)
        self.finger_forces = np.zeros((n, 2))
        self.object_pose = np.zeros((n, 7))
        self.phase = np.empty(n, dtype=object)
        self.events: list[tuple[float, str]] = []
        self.count = 0
        # Finger-object contacts, sampled (FingerContacts) on rows where a finger touches.
        self._contacts: list[tuple[int, np.ndarray, np.ndarray, np.ndarray]] = []
        self._touching = False
        self._last_contact_t = -np.inf

    def record(self, t: float, phase: str, forces: tuple[float, float]) -> None:
        k = self.count
        if k >= len(self.time):
            return
        d = self.scene.data
        h = self.handles
        self.time[k] = t
        self.qpos[k] = d.qpos
        self.q_active[k] = d.qpos[h.active_qpos]
        self.tcp_pose[k, :3] = d.xpos[h.tcp_body]
        self.tcp_pose[k, 3:] = d.xquat[h.tcp_body]
        self.ee_pose[k, :3] = d.xpos[h.ee_body]
        self.ee_pose[k, 3:] = d.xquat[h.ee_body]
        self.gripper_width[k] = float(np.sum(d.qpos[h.finger_qpos]))
        self.finger_forces[k] = forces
        self.object_pose[k, :3] = d.xpos[self.obj.body_id]
        self.object_pose[k, 3:] = d.xquat[self.obj.body_id]
        self.phase[k] = phase
        self._sample_contacts(k, t, forces[0] > 0.0 or forces[1] > 0.0)
        self.count = k + 1

    def _sample_contacts(self, k: int, t: float, touching: bool) -> None:
        if touching and (
            not self._touching or t - self._last_contact_t >= 1.0 / CONTACT_SAMPLE_RATE_HZ
        ):
            points, world_forces, fingers = self.scene.finger_contacts(self.arm, self.object_name)
            self._contacts.append((k, points, world_forces, fingers))
            self._last_contact_t = t
        elif self._touching and not touching:
            self._contacts.append((k, np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, np.int64)))
        self._touching = touching

    def event(self, t: float, text: str) -> None:
        self.events.append((t, text))

    def finish(self) -> ExecutionTrace:
        n = self.count
        return ExecutionTrace(
            time=self.time[:n].copy(),
            qpos=self.qpos[:n].copy(),
            q_active=self.q_active[:n].copy(),
            tcp_pose=self.tcp_pose[:n].copy(),
            ee_pose=self.ee_pose[:n].copy(),
            gripper_width=self.gripper_width[:n].copy(),
            finger_forces=self.finger_forces[:n].copy(),
            object_pose=self.object_pose[:n].copy(),
            phase=self.phase[:n].astype(str),
            events=list(self.events),
            contacts=self._finish_contacts(),
        )

    def _finish_contacts(self) -> FingerContacts:
        samples = self._contacts
        if not samples:
            return FingerContacts.empty()
        return FingerContacts(
            sampled=np.array([c[0] for c in samples], dtype=np.int64),
            row=np.concatenate([np.full(len(c[1]), c[0], dtype=np.int64) for c in samples]),
            position=np.concatenate([c[1] for c in samples]).reshape(-1, 3),
            force=np.concatenate([c[2] for c in samples]).reshape(-1, 3),
            finger=np.concatenate([c[3] for c in samples]).astype(np.int64),
        )
