"""Lanes: a fixed set of worlds on the device, each running episodes one after another.

Lockstep (``motion``) steps every world of a batch until the batch's longest span ends,
and a batch waits until enough jobs are planned: on an H100 (FR3 cube, 65,536 episodes) 23-33%
of the motion's world-steps were past the worlds' own spans, and the device idled while the
first batches filled. Here one ``mjw.Data`` of ``nlane`` worlds (one CUDA graph, captured once)
steps for the whole run; when a lane's job has recorded its span (control schedule, then the
validity window) the lane is free, and the host loads the next waiting job into it between two
replays of ``interval`` physics steps. A lane idles at most one interval per job.

A free lane may run a tug rung instead (``load_rungs``): the held state of a job slot with
the rung's pull, for the rung's physics steps, then one end row (``collect``'s ``rungs``). The
tug then costs lane-steps that would otherwise idle, not a batch of its own beside the lanes.

The jobs' arrays live in *job slots* (``capacity`` of them): the control schedule, the signal
rows, the warm-up row, the saved validity-window states, the held controls and mocap poses (the
tug's rungs start from them after the lane has moved on). A slot is freed by the caller once
the job is judged (``release``).

Every per-world kernel reads its lane's job through ``job_of``, so a job's rows are those of the
lockstep motion, bit for bit on Warp's CPU device (``tests/test_lanes.py``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import mujoco_warp as mjw
import numpy as np
import warp as wp

from harness.engines.mjwarp import kernels, steps
from harness.engines.mjwarp import lane_kernels as lk
from harness.engines.mjwarp.graph_loop import LoopGraph, graph_loop, try_loop_steps
from harness.engines.mjwarp.host import Downloads, to_host_all
from harness.engines.mjwarp.model import DeviceModel
from harness.engines.mjwarp.schedule import DeviceJob
from harness.engines.mjwarp.signals import SIGNALS
from harness.engines.mjwarp.steps import BatchTimings, Buffers


@dataclass
class Finished:
    """Jobs whose span ended in the last replay: their slots, signal rows (each cut to its
    span), warm-up rows, and whether their rows or contacts did not fit the buffers; and the
    rungs that ended in it (``RungsFinished``)."""

    slots: list[int]
    rows: list[np.ndarray]
    warm: list[np.ndarray]
    overflowed: list[bool]
    rungs: RungsFinished | None = None


@dataclass
class RungsFinished:
    """Tug rungs whose steps ended in the last replay: the caller's tags, their end rows, and
    whether their rows or contacts did not fit the buffers."""

    tags: list[int]
    rows: list[np.ndarray]
    overflowed: list[bool]


def _finished(
    slots: np.ndarray, spans: np.ndarray, over: np.ndarray, rows: np.ndarray, warm: np.ndarray
) -> Finished:
    """``Finished`` from downloaded rows (each cut to its job's span) and warm-up rows."""
    return Finished(
        [int(s) for s in slots],
        [rows[k, : spans[k]] for k in range(len(slots))],
        list(warm[:, 0]),
        [bool(v) for v in over],
    )


@dataclass
class _RowsInFlight:
    """Finished jobs whose rows a visit queued for download (``settle``)."""

    slots: np.ndarray
    spans: np.ndarray
    overflowed: np.ndarray
    handles: list[Any]
    keep: list[Any]  # the device arrays copied from, alive until the copies are read


class LaneRun:
    """``nlane`` lanes of one task model (``dm``) and ``capacity`` job slots on the device."""

    def __init__(
        self,
        dm: DeviceModel,
        nlane: int,
        capacity: int,
        rows: int,
        window: int,
        chunk_sizes: list[int],
        buffers: Buffers,
        make_data: Callable[[int], mjw.Data],
        interval: int,
        rungs: bool = False,
    ) -> None:
        """``rows``: the longest span a slot holds (control steps); ``window``: the validity
        window's control steps; ``interval``: physics steps between two host visits;
        ``rungs``: lanes may run tug rungs (``load_rungs``; else their kernels stay out of the
        graph)."""
        if dm.mj_model.na:
            raise ValueError("lanes do not reset actuator activations (model with na > 0)")
        self.dm, self.nlane, self.capacity, self.rows = dm, nlane, capacity, rows
        self.buffers, self.chunk_sizes = buffers, list(chunk_sizes)
        self.substeps = sum(chunk_sizes)
        self.slots = window + 1  # the saved states: the motion's last row and the window
        m = dm.mj_model
        nq, nv, nu = m.nq, m.nv, m.nu
        self.d = make_data(nlane)
        # per lane
        self.job_of = wp.full(nlane, -1, dtype=wp.int32)
        self.phase = wp.zeros(nlane, dtype=wp.int32)
        self.ended = wp.zeros(nlane, dtype=wp.int32)
        self.row_of = wp.full(nlane, kernels.NO_ROW, dtype=wp.int32)
        self.peak_rows = wp.zeros(nlane, dtype=wp.int32)
        self.peak_contacts = wp.zeros(1, dtype=wp.int32)
        self.rung_left = wp.zeros(nlane, dtype=wp.int32)  # a rung's physics steps to go
        self.rung_row = wp.full(nlane, kernels.NO_ROW, dtype=wp.int32)
        self.rung_out = wp.zeros((nlane, 1, SIGNALS), dtype=wp.float32)  # a rung's end row
        self.rung_pen = dm.penetration_start(nlane)  # (a rung's penetration is not judged)
        self.lane_index = wp.array(np.arange(nlane, dtype=np.int32), dtype=wp.int32)
        self.rung_arm = wp.zeros(nlane, dtype=wp.int32)  # a rung's arm (its job's)
        self.rungs = rungs
        # per job slot
        nchunks = len(chunk_sizes)
        self.table = wp.zeros((capacity, rows * nchunks, nu), dtype=wp.float32)
        self.last = wp.zeros(capacity, dtype=wp.int32)
        self.warmup = wp.zeros(capacity, dtype=wp.int32)
        self.span = wp.zeros(capacity, dtype=wp.int32)
        self.first_row = wp.zeros(capacity, dtype=wp.int32)
        self.arm_of = wp.zeros(capacity, dtype=wp.int32)  # the job's arm (a scene's arms share)
        self.out = wp.zeros((capacity, rows, SIGNALS), dtype=wp.float32)
        self.warm = wp.zeros((capacity, 1, SIGNALS), dtype=wp.float32)
        self.saved = [wp.zeros((capacity, self.slots, k), dtype=wp.float32) for k in (nq, nv, nv)]
        self.pen_initial = dm.penetration_start(capacity)
        self.hold_ctrl = wp.zeros((capacity, nu), dtype=wp.float32)
        self.mocap = [wp.zeros((capacity, m.nmocap), dtype=kind) for kind in (wp.vec3, wp.quat)]
        chunk_at = np.full(self.substeps, -1, dtype=np.int32)
        chunk_at[np.cumsum([0, *chunk_sizes[:-1]])] = np.arange(nchunks)
        self.chunk_at = wp.array(chunk_at, dtype=wp.int32)
        # the host's view: the job slot in each lane (-1: free), what each lane's job spans
        self.lane_job = np.full(nlane, -1, dtype=np.int64)
        self.lane_rung = np.full(nlane, -1, dtype=np.int64)  # the caller's tag of a lane's rung
        self.rung_steps = 0  # a rung's physics steps (set by ``load_rungs``)
        self._rung_flagged = np.zeros(nlane, dtype=bool)  # rung lanes while the pool was full
        self.span_host = np.zeros(capacity, dtype=np.int64)
        self.warmup_host = np.zeros(capacity, dtype=np.int64)
        self.motion_host = np.zeros(capacity, dtype=np.int32)  # the tug's ``RungStart.motion``
        self.arm_host = np.zeros(capacity, dtype=np.int32)
        # slots whose job was in a lane while the contact pool was full
        self._flagged = np.zeros(0, dtype=np.int64)
        self.interval = interval
        self._graph = None
        self._loop: LoopGraph | None = None  # with ``graph_loop``: its graph, counter, scratch
        # the pipelined visits (``queue`` / ``settle``): the visit count, the visit from whose
        # replay on each lane's job runs, the previous visit's downloads and its mark
        self._visit = 0
        self.loaded_at = np.zeros(nlane, dtype=np.int64)
        self._downloads = Downloads()
        self._state_prev: list[Any] | None = None  # the lanes' state after the last replay
        self._state_now: list[Any] | None = None
        self._rows_prev: _RowsInFlight | None = None
        self._mark: Any = None

    @property
    def busy(self) -> int:
        """Lanes holding a job or a rung."""
        return int(np.count_nonzero((self.lane_job >= 0) | (self.lane_rung >= 0)))

    def free_lanes(self) -> np.ndarray:
        return np.flatnonzero((self.lane_job < 0) & (self.lane_rung < 0))

    def load_rungs(
        self,
        lanes: np.ndarray,
        tags: np.ndarray,
        job_slots: np.ndarray,
        saved: np.ndarray,
        forces: np.ndarray,
        steps_each: int,
    ) -> None:
        """Start tug rungs in ``lanes`` (free): each from its job slot's saved state
        ``saved`` (the end of the hold) with its pull ``forces`` (N, world frame) on the
        object, for ``steps_each`` physics steps; ``tags`` name them in ``collect``."""
        if not self.rungs:
            raise ValueError("these lanes were made without rungs (LaneRun(rungs=True))")
        d, dm = self.d, self.dm
        lanes_w, source, slot = (wp.array(np.asarray(v, dtype=np.int32), dtype=wp.int32)
                                 for v in (lanes, job_slots, saved))  # fmt: skip
        wp.launch(
            kernels.load_rungs, dim=len(lanes),
            inputs=[
                lanes_w, source, slot, *self.saved, self.hold_ctrl, *self.mocap,
                wp.array(np.asarray(forces, dtype=np.float32), dtype=wp.vec3), dm.obj_body,
                d.qpos, d.qvel, d.qacc_warmstart, d.ctrl, d.mocap_pos, d.mocap_quat,
                d.xfrc_applied,
            ],
        )  # fmt: skip
        wp.launch(
            lk.lane_rung_start, dim=len(lanes),
            inputs=[lanes_w, steps_each, self.rung_left, self.peak_rows],
        )  # fmt: skip
        self._scatter(self.arm_host[np.asarray(job_slots)], lanes_w, self.rung_arm)
        self.lane_rung[lanes] = tags
        self.loaded_at[lanes] = self._visit + 1
        self.rung_steps = steps_each

    def load(
        self, lanes: np.ndarray, slots: np.ndarray, jobs: list[DeviceJob], span: np.ndarray
    ) -> None:
        """Start ``jobs`` in ``lanes`` (free) with their arrays in ``slots`` (free): the lane's
        state is the job's start state, its phase 0; ``span``: each job's control steps
        recorded (its motion, then the validity window when it has one)."""
        n = len(jobs)
        lanes_w = wp.array(lanes.astype(np.int32), dtype=wp.int32)
        slots_w = wp.array(slots.astype(np.int32), dtype=wp.int32)
        schedules = [job.schedule for job in jobs]
        motion = np.array([s.steps for s in schedules], dtype=np.int32)
        span = np.asarray(span, dtype=np.int32)
        table, last = steps.schedule_rows(schedules, self.rows)
        state = steps.world_arrays(jobs)
        arms = np.array([self.dm.arm_index(job.task.arm) for job in jobs], dtype=np.int32)
        d = self.d
        for name, values in state.items():
            self._scatter(values.astype(np.float32), lanes_w, getattr(d, name))
        per_lane = (self.job_of, slots), (self.phase, 0), (self.ended, 0), (self.peak_rows, 0)
        for target, value in per_lane:
            self._scatter(np.broadcast_to(np.asarray(value, np.int32), (n,)), lanes_w, target)
        per_slot = (
            (self.table, table), (self.last, last),
            (self.warmup, np.array([s.warmup_steps for s in schedules], np.int32)),
            (self.span, span), (self.first_row, motion - 1), (self.arm_of, arms),
            (self.hold_ctrl, table[np.arange(n), last]),
            (self.mocap[0], state["mocap_pos"].astype(np.float32)),
            (self.mocap[1], state["mocap_quat"].astype(np.float32)),
        )  # fmt: skip
        for target, values in per_slot:
            self._scatter(values, slots_w, target)
        self.lane_job[lanes] = slots
        self.loaded_at[lanes] = self._visit + 1  # runs from the next queued replay on
        self.span_host[slots] = span
        self.warmup_host[slots] = [s.warmup_steps for s in schedules]
        self.motion_host[slots] = motion
        self.arm_host[slots] = arms

    @staticmethod
    def _scatter(values: np.ndarray, index: wp.array, target: wp.array) -> None:
        src = wp.array(np.ascontiguousarray(values), dtype=target.dtype, device=target.device)
        kernel = {1: lk.scatter_1d, 2: lk.scatter_2d, 3: lk.scatter_3d}[target.ndim]
        wp.launch(kernel, dim=src.shape, inputs=[src, index, target])

    def _physics_step(self) -> None:
        dm, d = self.dm, self.d
        wp.launch(
            lk.lane_ctrl, dim=(self.nlane, d.ctrl.shape[1]),
            inputs=[
                self.table, self.last, self.warmup, self.job_of, self.phase, self.chunk_at,
                len(self.chunk_sizes), d.ctrl,
            ],
        )  # fmt: skip
        mjw.step(dm.model, d)
        wp.launch(
            lk.lane_track,
            dim=self.nlane,
            inputs=[d.nefc, d.nacon, self.peak_rows, self.peak_contacts],
        )
        wp.launch(
            lk.lane_tick, dim=self.nlane,
            inputs=[
                self.warmup, self.span, self.substeps, self.job_of, self.phase, self.ended,
                self.row_of,
            ],
        )  # fmt: skip
        dm.record(d, self.row_of, self.out, self.warm, self.pen_initial, self.job_of, self.arm_of)
        if self.rungs:
            wp.launch(
                lk.lane_rung_tick, dim=self.nlane,
                inputs=[self.rung_left, dm.obj_body, d.xfrc_applied, self.rung_row],
            )  # fmt: skip
            rung_rows = self.rung_row, self.rung_out, self.rung_out, self.rung_pen
            dm.record(d, *rung_rows, self.lane_index, self.rung_arm)
        wp.launch(
            kernels.save_state, dim=self.nlane,
            inputs=[
                d.qpos, d.qvel, d.qacc_warmstart, self.first_row, self.slots, self.row_of,
                self.job_of, *self.saved,
            ],
        )  # fmt: skip
        wp.launch(lk.lane_release, dim=self.nlane, inputs=[self.job_of, self.ended])

    def launch(
        self, timings: BatchTimings, launch_graph: Callable[[Any], None] = steps.launch_in_place
    ) -> None:
        """Queue ``interval`` physics steps of every lane: one captured CUDA graph (the steps
        unrolled, or with ``graph_loop`` one step in a device-side loop), captured at the first
        call after one eager step that loads the kernels (on Warp's CPU device: eagerly),
        replayed with ``launch_graph`` (the slot's: ``DeviceSlot.launch``)."""
        self.peak_contacts.zero_()
        count = self.interval
        if not wp.get_device(self.dm.device).is_cuda:
            for _ in range(count):
                self._physics_step()
        else:
            if self._graph is None:
                self._physics_step()
                count += 1
                if graph_loop():  # one step's kernels in a device-side loop
                    self._loop = try_loop_steps(self.dm.device, self._physics_step, self.interval)
                    count += 1  # its step recording the scratch
                if self._loop is not None:
                    self._graph = self._loop.graph
                    timings.loop_graphs += 1
                else:
                    with wp.ScopedCapture(device=self.dm.device) as capture:
                        for _ in range(self.interval):
                            self._physics_step()
                    self._graph = capture.graph
            assert self._graph is not None
            launch_graph(self._graph)
        timings.motion_steps += self.nlane * count
        timings.world_steps += self.nlane * count

    def collect(self, timings: BatchTimings) -> Finished:
        """After the queued steps are done: the jobs whose span ended (their lanes are free)."""
        state = [self.job_of, self.peak_rows, self.peak_contacts]
        job_of, peak_rows, contacts, *rung_left = to_host_all(
            [*state, self.rung_left] if self.rungs else state
        )
        rungs = None
        if rung_left:
            rungs = self._rungs_ended(rung_left[0], peak_rows, int(contacts[0]), timings)
        slots, spans, over = self._retire(job_of, peak_rows, int(contacts[0]), timings)
        if len(slots) == 0:
            return Finished([], [], [], [], rungs)
        rows, warm = to_host_all(list(self._gather(slots)[1:]))
        finished = _finished(slots, spans, over, rows, warm)
        finished.rungs = rungs
        return finished

    def _rungs_ended(
        self, rung_left: np.ndarray, peak_rows: np.ndarray, contacts: int, timings: BatchTimings
    ) -> RungsFinished | None:
        """The rungs whose steps ended in the last replay leave their lanes: their tags, end
        rows (downloaded now) and whether they did not fit the buffers (their constraint rows,
        or a full contact pool in the replay)."""
        ran = self.lane_rung >= 0
        if not ran.any():
            return None
        if contacts > self.d.naconmax:  # every rung that ran may have lost a contact
            self._rung_flagged[ran] = True
        lanes = np.flatnonzero(ran & (rung_left <= 0))
        tags = self.lane_rung[lanes].copy()
        flagged = self._rung_flagged[lanes].copy()
        self.lane_rung[lanes] = -1
        self._rung_flagged[lanes] = False
        timings.span_steps += len(lanes) * self.rung_steps
        timings.tug_rungs += len(lanes)
        if len(lanes) == 0:
            return None
        index = wp.array(lanes.astype(np.int32), dtype=wp.int32)
        rows = wp.empty((len(lanes), 1, SIGNALS), dtype=float)
        wp.launch(lk.gather_rows, dim=rows.shape, inputs=[self.rung_out, index, rows])
        host_rows = to_host_all([rows])[0]
        over = (peak_rows[lanes] > self.buffers.njmax) | flagged
        return RungsFinished(
            [int(t) for t in tags], [host_rows[k, 0] for k in range(len(lanes))],
            [bool(v) for v in over],
        )  # fmt: skip

    def _retire(
        self,
        job_of: np.ndarray,
        peak_rows: np.ndarray,
        contacts: int,
        timings: BatchTimings,
        loaded_before: int | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """From the lanes' state after a replay: the jobs whose span ended in it leave their
        lanes; their slots, spans and whether their rows or contacts did not fit (a full
        contact pool: every job that ran in the replay may have lost a contact). Only lanes
        loaded before visit ``loaded_before`` ran in it (None: every busy lane)."""
        ran = self.lane_job >= 0
        if loaded_before is not None:
            ran &= self.loaded_at < loaded_before
        done_lanes = np.flatnonzero(ran & (job_of < 0))
        timings.peak_contacts = max(timings.peak_contacts, contacts / max(1, self.nlane))
        if contacts > self.d.naconmax:
            self._flagged = np.union1d(self._flagged, self.lane_job[ran])
        slots = self.lane_job[done_lanes].copy()
        peaks = peak_rows[done_lanes]
        timings.peak_rows = max(timings.peak_rows, int(peaks.max(initial=0)))
        spans = self.span_host[slots]
        timings.span_steps += int(np.sum(self.warmup_host[slots] + spans * self.substeps))
        self.lane_job[done_lanes] = -1
        over = (peaks > self.buffers.njmax) | np.isin(slots, self._flagged)
        return slots, spans, over

    def _gather(self, slots: np.ndarray) -> tuple[wp.array, wp.array, wp.array]:
        """The slots' index, signal rows and warm-up rows gathered on the device."""
        index = wp.array(slots.astype(np.int32), dtype=wp.int32)
        rows = wp.empty((len(slots), self.rows, SIGNALS), dtype=float)
        wp.launch(lk.gather_rows, dim=rows.shape, inputs=[self.out, index, rows])
        warm = wp.empty((len(slots), 1, SIGNALS), dtype=float)
        wp.launch(lk.gather_rows, dim=warm.shape, inputs=[self.warm, index, warm])
        return index, rows, warm

    # ---- pipelined visits: the next replay is queued before the last one is collected

    @property
    def in_flight(self) -> bool:
        """(pipelined) A replay or a download is queued that ``settle`` has not collected."""
        rows = self._rows_prev is not None and len(self._rows_prev.slots) > 0
        return self._state_now is not None or self._state_prev is not None or rows

    def queue(self, timings: BatchTimings, launch_graph: Callable[[Any], None]) -> bool:
        """(pipelined) Queue one replay of every lane (``launch``) and the download of the
        lanes' state at its end, behind what the device still runs; False (nothing queued)
        when no lane holds a job."""
        self._visit += 1
        self._state_prev, self._state_now = self._state_now, None
        if not self.busy:
            return False
        self.launch(timings, launch_graph)
        self._state_now = self._downloads.queue(
            ("state", self._visit % 2), [self.job_of, self.peak_rows, self.peak_contacts]
        )
        return True

    def settle(
        self, timings: BatchTimings, wait: Callable[[Any], None], mark: Callable[[], Any]
    ) -> Finished:
        """(pipelined) Wait until the device is past the previous visit's work (its replay,
        state and rows downloads; the replay ``queue`` just queued may run on), then: the jobs
        the previous replay finished leave their lanes (free for the next ``load``) and their
        rows are queued for download; returned are the jobs whose rows the previous visit
        downloaded. A job's lane so idles at most two replays, and its rows come one visit
        after its lane is free."""
        if self._mark is not None:
            wait(self._mark)
        ready = self._rows_prev
        self._rows_prev = self._learn(timings)
        self._mark = mark()
        if ready is None or len(ready.slots) == 0:
            return Finished([], [], [], [])
        rows, warm = (Downloads.read(h) for h in ready.handles)
        return _finished(ready.slots, ready.spans, ready.overflowed, rows, warm)

    def _learn(self, timings: BatchTimings) -> _RowsInFlight | None:
        """The jobs the previous visit's replay finished (from its state download): their
        lanes are freed and their rows queued for download."""
        if self._state_prev is None:
            return None
        job_of, peak_rows, contacts = (Downloads.read(h) for h in self._state_prev)
        self._state_prev = None
        slots, spans, over = self._retire(
            job_of, peak_rows, int(contacts[0]), timings, loaded_before=self._visit
        )
        if len(slots) == 0:
            return _RowsInFlight(slots, spans, over, [], [])
        gathered = self._gather(slots)
        handles = self._downloads.queue(("rows", self._visit % 2), list(gathered[1:]))
        return _RowsInFlight(slots, spans, over, handles, list(gathered))

    def release(self, slots: list[int]) -> None:
        """The slots' jobs are judged: the slots can take new jobs."""
        self._flagged = np.setdiff1d(self._flagged, slots)
