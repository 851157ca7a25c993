"""Many execution jobs of one task model stepped in lockstep on MuJoCo Warp.

One ``mjw.Model`` per task model (``model.DeviceModel``), one ``mjw.Data`` of ``len(jobs)``
worlds per batch. Each world starts from its job's reset state (qpos, qvel, mocap pose, warm
start), runs the reference's warm-up steps with the home controls, then its control schedule
(``schedule``): the schedule lives on the device as (world, chunk row, actuator)
and a device step counter indexes it inside the captured CUDA graph of one control step (setting
the controls, the physics steps of each servo chunk, recording the signals, saving the validity
window's states); the host replays that graph once per control step. Worlds whose schedule ended
hold their last controls. The validity phase's tug runs in rounds of rung batches
(``harness.engines.mjwarp.tug``): each rung is a world started from its episode's state at the
end of the hold with its pull in ``xfrc_applied``; round 1 runs every tugged episode's six
directions at the top level, each later round the rungs its ladder still asks for. On Warp's
CPU device the same functions run without capture.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass

import mujoco_warp as mjw
import numpy as np
import warp as wp

from harness.engines.mjwarp import kernels, steps
from harness.engines.mjwarp.graph_loop import graph_loop
from harness.engines.mjwarp.host import to_host
from harness.engines.mjwarp.judge import held_in_tcp, judge_started, needs_tug, rung_outcome
from harness.engines.mjwarp.model import DeviceModel
from harness.engines.mjwarp.motion import MotionRun
from harness.engines.mjwarp.retirement import MIN_WORLDS, RETIRE, segments
from harness.engines.mjwarp.schedule import DeviceJob
from harness.engines.mjwarp.signals import (
    SIGNALS,
    HoldWindow,
    hold_window,
    window_steps,
)
from harness.engines.mjwarp.slot import DeviceSlot
from harness.engines.mjwarp.steps import LARGE, SMALL, BatchTimings, Buffers
from harness.engines.mjwarp.tug import (
    DEFAULT_POLICY,
    RoundPolicy,
    Rung,
    run_rounds,
    rung_pull,
    rung_start_slot,
    steps_per_graph,
)
from harness.pick.outcome import PickOutcome
from harness.pick.validity import (
    RungOutcome,
    tug_rung_steps,
    validity_enabled,
)

# The most rung-worlds stepped at once: a round of a large batch (six rungs per tugged world:
# ~98,000 worlds for a batch of 16,384) runs in parts of at most this many, so that its device
# memory stays within a batch of this size whatever the batch. Chosen, no public source: the
# first round of an 8,192-world batch (~46,000 rung-worlds) ran in one part on an H100 80GB
# with a 25 GB high-water mark.
MAX_RUNG_WORLDS = 32_768


class WorldBatch:
    """Runs jobs of one ``DeviceModel`` in lockstep and judges them (``run``)."""

    def __init__(
        self,
        dm: DeviceModel,
        policy: RoundPolicy = DEFAULT_POLICY,
        buffers: Buffers = SMALL,
        slot: DeviceSlot | None = None,
        retire: float = RETIRE,
    ) -> None:
        self.dm = dm
        # the stream this batch runs on (and the lock of the device's slots); own by default
        self.slot = slot if slot is not None else DeviceSlot(dm.device)
        self.policy = policy  # which rungs each tug round runs
        self.buffers = buffers
        # when worlds leave the motion (``retirement.segments``); retire 0: lockstep
        self.retire, self.min_worlds = retire, MIN_WORLDS
        self.timings = BatchTimings()
        # the worlds of the current ``_run`` that did not fit: their steps, or a tug round of
        # theirs even on ``LARGE``
        self._overflowed: set[int] = set()

    def data(self, nworld: int, buffers: Buffers) -> mjw.Data:
        """A fresh data of ``nworld`` worlds on ``buffers``."""
        return mjw.put_data(
            self.dm.mj_model, self.dm.template, nworld=nworld,
            nconmax=buffers.nconmax, njmax=buffers.njmax,
        )  # fmt: skip

    def run(self, jobs: list[DeviceJob]) -> list[PickOutcome]:
        """The jobs' outcomes. Worlds whose contacts or constraint rows did not fit
        ``self.buffers`` run again with ``LARGE``; those that do not fit it either end as
        ``sim_unstable`` (the CPU scene's full-buffer test)."""
        with self.slot:  # every Warp call of the batch on its slot's stream
            return self._run_fitted(jobs)

    def _run_fitted(self, jobs: list[DeviceJob]) -> list[PickOutcome]:
        outcomes, over = self._run(jobs, self.buffers)
        if over and self.buffers != LARGE:
            self.timings.reruns += len(over)
            again, over_again = self._run([jobs[i] for i in over], LARGE)
            for i, outcome in zip(over, again, strict=True):
                outcomes[i] = outcome
            over = [over[k] for k in over_again]
        for i in over:
            outcomes[i] = PickOutcome(
                failure_reason="sim_unstable",
                message=(
                    f"the contact or constraint buffer was full ({LARGE.nconmax} contacts, "
                    f"{LARGE.njmax} constraint rows per world)"
                ),
            )
        return outcomes

    def _run(self, jobs: list[DeviceJob], buffers: Buffers) -> tuple[list[PickOutcome], list[int]]:
        """The jobs on ``buffers``: their outcomes and the worlds that did not fit."""
        dm, device = self.dm, self.dm.device
        schedules = [job.schedule for job in jobs]
        validity = [validity_enabled(job.task.pick) for job in jobs]
        dt = schedules[0].control_dt
        hold_time = jobs[0].task.pick.hold_time
        window = window_steps(hold_time, dt)
        motion = np.array([s.steps for s in schedules], dtype=np.int32)
        spans = motion + np.where(validity, window, 0)
        clock = time.perf_counter()
        with wp.ScopedDevice(device):
            run = MotionRun(dm, jobs, spans, window, lambda k: self.data(k, buffers))
            self.slot.wait()
            self.timings.upload_s += time.perf_counter() - clock
            clock = time.perf_counter()
            plan = segments(spans, self.retire, self.min_worlds)
            over = run.run(plan, buffers, self.timings, self.slot.wait)
            self.timings.physics_s += time.perf_counter() - clock
            clock = time.perf_counter()
            steps = to_host(run.out)
            warm_rows = to_host(run.warm)[:, 0]
            self.timings.download_s += time.perf_counter() - clock
            self._overflowed = set(over)  # not judged: they run again, or end unstable
            worlds = list(range(len(jobs)))
            windows, tugged = hold_windows(jobs, worlds, steps, validity, self._overflowed)
            arms = {w: job.task.arm for w, job in enumerate(jobs)}
            start = RungStart(jobs, run.saved, run.hold_ctrl, run.mocap, motion, windows, arms)
            rungs = self._tug(start, steps, tugged, buffers)
        clock = time.perf_counter()
        outcomes = [
            judge_started(job, steps[w], warm_rows[w], validity[w], windows[w], rungs.get(w))
            for w, job in enumerate(jobs)
        ]
        self.timings.judge_s += time.perf_counter() - clock
        return outcomes, sorted(self._overflowed)

    def run_held(self, jobs: list[DeviceJob]) -> list[PickOutcome]:
        """``run`` for a caller that holds this batch's slot already."""
        return self._run_fitted(jobs)

    def tug(
        self, start: RungStart, rows: Mapping[int, np.ndarray], tugged: list[int]
    ) -> tuple[dict[int, dict[Rung, RungOutcome]], set[int]]:
        """The tug ladders of ``tugged`` (worlds of ``start``) on this batch's buffers: by
        world, the rungs' outcomes, and the worlds whose rungs did not fit even ``LARGE``."""
        self._overflowed = set()
        rungs = self._tug(start, rows, tugged, self.buffers)
        return rungs, self._overflowed

    def _tug(
        self,
        start: RungStart,
        steps: np.ndarray | Mapping[int, np.ndarray],
        tugged: list[int],
        buffers: Buffers,
    ) -> dict[int, dict[Rung, RungOutcome]]:
        """The tug ladders of the tugged worlds, in rounds (``self.policy``) on the batch's
        ``buffers``; by world, the outcomes of the rungs its ladder asked for."""
        if not tugged:
            return {}
        held = {w: held_in_tcp(steps[w], _window(start.windows[w])) for w in tugged}

        def run(batch: list[tuple[int, Rung]]) -> list[RungOutcome]:
            outcomes = []
            for k in range(0, len(batch), MAX_RUNG_WORLDS):
                part = batch[k : k + MAX_RUNG_WORLDS]
                rows = self._rungs(start, part, buffers)
                outcomes += [
                    rung_outcome(row, held[w]) for (w, _), row in zip(part, rows, strict=True)
                ]
            return outcomes

        known, stats = run_rounds(tugged, run, self.policy)
        self.timings.tug_rounds += stats.rounds
        self.timings.tug_rungs += stats.rungs
        return known

    def _rungs(
        self, start: RungStart, batch: list[tuple[int, Rung]], buffers: Buffers
    ) -> np.ndarray:
        """One round: a world per (world, rung), started from that world's held state with the
        rung's pull; their end rows in ``batch`` order. A round whose worlds did not fit
        ``buffers`` runs again with ``LARGE``; the episodes of rungs that do not fit it either
        are noted (``self._overflowed``)."""
        clock = time.perf_counter()
        dm = self.dm
        source, slot, force = [], [], []
        for w, rung in batch:
            source.append(w)
            slot.append(rung_start_slot(_window(start.windows[w]).hold_end, int(start.motion[w])))
            force.append(rung_pull(rung, dm.weight))
        nt = len(batch)
        td = self.data(nt, buffers)
        wp.launch(
            kernels.load_rungs, dim=nt,
            inputs=[
                wp.array(np.arange(nt, dtype=np.int32), dtype=wp.int32),
                wp.array(np.asarray(source, dtype=np.int32), dtype=wp.int32),
                wp.array(np.asarray(slot, dtype=np.int32), dtype=wp.int32),
                *start.saved, start.hold_ctrl, *start.mocap,
                wp.array(np.asarray(force, dtype=np.float32), dtype=wp.vec3), dm.obj_body,
                td.qpos, td.qvel, td.qacc_warmstart, td.ctrl, td.mocap_pos, td.mocap_quat,
                td.xfrc_applied,
            ],
        )  # fmt: skip
        physics_steps = rung_physics_steps(dm, float(start.jobs[0].task.control_dt))
        use = steps.BufferUse(nt)
        loop = steps.replay(
            dm.device, steps.stepper(dm.model, td, use), physics_steps, self.slot.launch,
            per_graph=steps_per_graph(), looped=graph_loop(),
        )  # fmt: skip
        out = wp.zeros((nt, 1, SIGNALS), dtype=wp.float32)
        identity = wp.array(np.arange(nt, dtype=np.int32), dtype=wp.int32)
        # the rungs' penetration is not judged: each rung row measures its own start
        start_rows = wp.full(nt, kernels.BASELINE, dtype=wp.int32)
        arm_of = dm.arms_of([start.arms[w] for w, _ in batch])
        dm.record(td, start_rows, out, out, dm.penetration_start(nt), identity, arm_of)
        self.timings.tug_issue_s += time.perf_counter() - clock
        self.timings.loop_graphs += int(loop is not None)
        self.slot.wait()
        del loop  # (with ``graph_loop``) its counter and scratch live until the round has run
        rows = to_host(out)[:, 0]
        over = use.overflowed(td, buffers, self.timings)
        self.timings.tug_s += time.perf_counter() - clock
        self.timings.world_steps += nt * physics_steps
        if over and buffers != LARGE:
            self.timings.reruns += nt
            return self._rungs(start, batch, LARGE)
        self._overflowed.update(batch[r][0] for r in over)
        return rows


def rung_physics_steps(dm: DeviceModel, control_dt: float) -> int:
    """A tug rung's physics steps: ``tug_rung_steps`` control steps of the task's control
    period, in whole physics steps."""
    timestep = float(dm.mj_model.opt.timestep)
    substeps = max(1, round(control_dt / timestep))
    return tug_rung_steps(substeps * timestep) * substeps


@dataclass
class RungStart:
    """Where a batch's tug rungs start from: its jobs, its worlds' saved validity window states
    and held controls and mocap poses, each world's motion length and hold window."""

    jobs: list[DeviceJob]
    saved: list[wp.array]
    hold_ctrl: wp.array  # (world, nu): the controls each world holds after its schedule
    mocap: list[wp.array]  # (world, body): the mocap positions and orientations
    motion: np.ndarray  # per world: its motion's control steps
    windows: Mapping[int, HoldWindow | None]
    arms: Mapping[int, str]  # per world: its job's arm (whose fingers hold the object)


def hold_windows(
    jobs: list[DeviceJob],
    worlds: list[int],
    rows: np.ndarray | Mapping[int, np.ndarray],
    validity: list[bool],
    skip: set[int],
) -> tuple[dict[int, HoldWindow | None], list[int]]:
    """Each world's validity window (``None``: no validity phase, the verdict was not reached,
    or the world is in ``skip``), and the worlds the CPU phase would tug, in order."""
    windows: dict[int, HoldWindow | None] = {}
    tugged: list[int] = []
    for k, (w, job) in enumerate(zip(worlds, jobs, strict=True)):
        win = None
        schedule = job.schedule
        if validity[k] and schedule.verdict_step >= 0 and w not in skip:
            hold_time = job.task.pick.hold_time
            win = hold_window(rows[w], schedule.steps, hold_time, schedule.control_dt)
            if needs_tug(rows[w], win, float(job.object_init_position[2])):
                tugged.append(w)
        windows[w] = win
    return windows, tugged


def _window(window: HoldWindow | None) -> HoldWindow:
    assert window is not None, "a tugged world has a hold window"
    return window
