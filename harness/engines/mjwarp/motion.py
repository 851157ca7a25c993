"""The motion of a batch of worlds on the device, finished worlds retired as it goes.

Lockstep steps every world of a batch until the longest span in it ends (a world's span: its
control schedule, then the validity window). FR3 cube schedules run 101-277 control steps, so
even batches of similar lengths stepped 18% of their motion's world-steps past the worlds' own
spans, and batches fed from a short queue 44% (H100, 32,768 episodes, 2026-11-26). With a
retirement share above 0 (``retirement.RETIRE``, ``MjwarpEngine(retire=...)``, the bench's
``BENCH_RETIRE``; the default is lockstep, see ``retirement.RETIRE`` for why) the motion runs in
segments: when that share of the stepping worlds has reached the end of its span, the others go
on in a smaller MuJoCo Warp ``Data``, their state carried over (``kernels.carry_state``: what
``mj_step`` reads from the last step; the mocap poses are the jobs'). The signal rows, the saved
validity-window states and the control schedule stay in arrays of the whole batch, which each
segment's kernels index through its world map
(``world_of``: the batch world of each stepped world). A world's physics does not read the other
worlds of its data, so its rows are the lockstep run's (``tests/test_engines.py`` compares both
on Warp's CPU device).
"""

from __future__ import annotations

from collections.abc import Callable

import mujoco_warp as mjw
import numpy as np
import warp as wp

from harness.engines.mjwarp import kernels, steps
from harness.engines.mjwarp.model import DeviceModel
from harness.engines.mjwarp.retirement import Segment
from harness.engines.mjwarp.schedule import DeviceJob
from harness.engines.mjwarp.signals import SIGNALS
from harness.engines.mjwarp.steps import BatchTimings, Buffers


class MotionRun:
    """One batch's motion: its arrays over the batch's worlds and the segments' data."""

    def __init__(
        self,
        dm: DeviceModel,
        jobs: list[DeviceJob],
        spans: np.ndarray,
        window: int,
        make_data: Callable[[int], mjw.Data],
    ) -> None:
        n, rows = len(jobs), int(spans.max())
        schedules = [job.schedule for job in jobs]
        motion = np.array([s.steps for s in schedules], dtype=np.int32)
        self.dm, self.jobs, self.spans, self.make_data = dm, jobs, spans, make_data
        self.state = steps.world_arrays(jobs)
        table, last = steps.schedule_rows(schedules, rows)
        self.table = wp.array(table, dtype=wp.float32)
        self.last = wp.array(last, dtype=wp.int32)
        # after its schedule a world holds its last controls, and its mocap pose throughout
        # (the tug's rungs start from them)
        self.hold_ctrl = wp.array(table[np.arange(n), last], dtype=wp.float32)
        self.mocap = [
            wp.array(self.state[name], dtype=kind)
            for name, kind in (("mocap_pos", wp.vec3), ("mocap_quat", wp.quat))
        ]
        self.step = wp.zeros(1, dtype=wp.int32)
        self.out = wp.zeros((n, rows, SIGNALS), dtype=wp.float32)
        self.warm = wp.zeros((n, 1, SIGNALS), dtype=wp.float32)
        self.slots = window + 1
        nq, nv = dm.mj_model.nq, dm.mj_model.nv
        self.saved = [wp.zeros((n, self.slots, k), dtype=wp.float32) for k in (nq, nv, nv)]
        self.first_row = wp.array(motion - 1, dtype=wp.int32)
        self.pen_initial = dm.penetration_start(n)
        self.arm_of = dm.arms_of([job.task.arm for job in jobs])  # per batch world
        self.chunk_sizes = schedules[0].chunk_sizes
        self.warmup_steps = schedules[0].warmup_steps

    def _first(self, worlds: np.ndarray) -> mjw.Data:
        d = self.make_data(len(worlds))
        for name, values in self.state.items():
            getattr(d, name).assign(values[worlds].astype(np.float32))
        return d

    def _carry(self, d: mjw.Data, before: Segment, worlds: np.ndarray) -> mjw.Data:
        """A data of ``worlds`` (a subset of ``before.worlds``, same order) in ``d``'s state."""
        nd = self.make_data(len(worlds))
        for name in ("mocap_pos", "mocap_quat"):
            getattr(nd, name).assign(self.state[name][worlds].astype(np.float32))
        pick = np.flatnonzero(np.isin(before.worlds, worlds)).astype(np.int32)
        wp.launch(
            kernels.carry_state, dim=len(worlds),
            inputs=[
                wp.array(pick, dtype=wp.int32), d.time, d.qpos, d.qvel, d.act,
                d.qacc_warmstart, d.ctrl, nd.time, nd.qpos, nd.qvel, nd.act,
                nd.qacc_warmstart, nd.ctrl,
            ],
        )  # fmt: skip
        return nd

    def _control_step(self, d: mjw.Data, world_of: wp.array, physics_step: Callable[[], None]):  # type: ignore[no-untyped-def]
        chunks = self.chunk_sizes
        row_of = wp.zeros(d.nworld, dtype=wp.int32)

        def control_step() -> None:
            for chunk, size in enumerate(chunks):
                wp.launch(
                    kernels.set_ctrl, dim=(d.nworld, d.ctrl.shape[1]),
                    inputs=[self.table, self.step, chunk, len(chunks), self.last, world_of, d.ctrl],
                )  # fmt: skip
                for _ in range(size):
                    physics_step()
            wp.launch(kernels.rows_at_step, dim=d.nworld, inputs=[self.step, row_of])
            self.dm.record(d, row_of, self.out, self.warm, self.pen_initial, world_of, self.arm_of)
            wp.launch(
                kernels.save_state, dim=d.nworld,
                inputs=[
                    d.qpos, d.qvel, d.qacc_warmstart, self.first_row, self.slots, row_of,
                    world_of, *self.saved,
                ],
            )  # fmt: skip
            wp.launch(kernels.advance, dim=1, inputs=[self.step])

        return control_step

    def run(
        self,
        plan: list[Segment],
        buffers: Buffers,
        timings: BatchTimings,
        wait: Callable[[], None],
    ) -> list[int]:
        """Warm-up, then ``plan``'s segments; the batch worlds whose rows or contacts did not
        fit ``buffers``. ``wait`` (the slot's: other slots may use the device meanwhile) at
        each segment's end, before its buffer use is read."""
        dm, device = self.dm, self.dm.device
        substeps = sum(self.chunk_sizes)
        stepped = timings.motion_steps
        over: list[int] = []
        d, start, before = self._first(plan[0].worlds), 0, plan[0]
        for index, segment in enumerate(plan):
            if index > 0:
                d = self._carry(d, before, segment.worlds)
            world_of = wp.array(segment.worlds, dtype=wp.int32)
            use = steps.BufferUse(len(segment.worlds))
            physics_step = steps.stepper(dm.model, d, use)
            if index == 0:
                steps.replay(device, physics_step, self.warmup_steps)
                start_rows = wp.full(d.nworld, kernels.BASELINE, dtype=wp.int32)
                dm.record(
                    d, start_rows, self.out, self.warm, self.pen_initial, world_of, self.arm_of
                )
                timings.motion_steps += len(segment.worlds) * self.warmup_steps
            control_step = self._control_step(d, world_of, physics_step)
            steps.replay(device, control_step, segment.end - start)
            timings.motion_steps += len(segment.worlds) * (segment.end - start) * substeps
            wait()
            over += [int(segment.worlds[w]) for w in use.overflowed(d, buffers, timings)]
            start, before = segment.end, segment
        n = len(self.jobs)
        timings.span_steps += n * self.warmup_steps + int(self.spans.sum()) * substeps
        timings.world_steps += timings.motion_steps - stepped
        return sorted(set(over))
