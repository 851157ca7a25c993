"""Jobs streamed through lanes (``lanes``) as they are planned, judged in groups.

The caller hands jobs over while it plans more (``source``); each free lane takes the next one.
Between two replays the host collects the jobs whose span ended and judges earlier ones while
the device steps. With ``HARNESS_TUG_LANES=1`` a finished job that the validity phase
tugs opens its ladder (``lane_tug``): its rungs queue for free lanes, ahead of new jobs, and
each ladder asks for its next rungs as soon as its last ones ended; its slot is freed when the
ladder is complete. By default (measured no faster, ``lane_tug.tug_in_lanes``) finished jobs
wait in a group until ``group`` of them, the end of the
stream, ``GROUP_WAIT_S`` since the group's first, or as many as the lanes still step (so that a
caller waiting for its outcomes before it plans more is never held back by a group that cannot
fill): their tug ladders then run in rounds (``WorldBatch.tug``: the rounds are as large as the
group's tugged worlds) in a thread of the stream's own, on a CUDA stream of its own, while the
lanes go on stepping (run in line, the FR3 cube sweep's 15 rounds held its lanes for 9 of its
53 s, 2026-11-27); their slots are freed once their tug is done. Jobs whose span exceeds the
slots' rows, and jobs whose rows or contacts did not fit the buffers, run afterwards as
lockstep batches (``WorldBatch``: the large buffers, and ``sim_unstable`` when even those are
full), exactly as a lockstep batch would rerun them.
"""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Callable, Hashable
from concurrent.futures import Future, ThreadPoolExecutor, wait
from dataclasses import dataclass

import numpy as np
import warp as wp

from harness.engines.mjwarp.batch import (
    LARGE,
    RungStart,
    WorldBatch,
    hold_windows,
    rung_physics_steps,
)
from harness.engines.mjwarp.judge import judge_started
from harness.engines.mjwarp.lane_sizes import env_flag, env_int
from harness.engines.mjwarp.lane_tug import Ladder, LaneLadders, tug_in_lanes
from harness.engines.mjwarp.lanes import Finished, LaneRun, RungsFinished
from harness.engines.mjwarp.schedule import DeviceJob
from harness.engines.mjwarp.signals import HoldWindow, window_steps
from harness.engines.mjwarp.slot import DeviceSlot
from harness.engines.mjwarp.stream_stats import add_timings, occupancy
from harness.engines.mjwarp.tug import Rung
from harness.pick.outcome import PickOutcome
from harness.pick.validity import RungOutcome, validity_enabled

# The longest span (control steps) a job slot holds; longer jobs run as lockstep batches.
# Chosen, no public source: FR3 cube spans reach ~340 (277 control steps and the window).
LANE_ROWS = 512
# Control steps between two host visits: a lane idles at most this long per job. Chosen, no
# public source: ~3% of an FR3 cube span (~260 control steps). ``HARNESS_LANE_INTERVAL``
# overrides it (fewer visits for streams of a few lanes, whose host work per visit may outweigh
# their device work: the demo's case, not yet measured).
INTERVAL_CONTROL_STEPS = 8
# Finished jobs per tug group: the first round runs ~6 rung-worlds per tugged job.
TUG_GROUP = 4096
# Queue the lanes' next replay before the host collects the last one (a lane then idles up to
# two replays per job instead of one, and the device never waits for the host's visit).
AHEAD_ENV = "HARNESS_LANE_AHEAD"
# The longest a finished job waits in a group for its tug (s). Chosen, no public source: long
# against a tug round (~0.2 s of device time), short against an episode's planning on a pool.
GROUP_WAIT_S = 10.0

# What the caller's source gives: new (key, job) pairs, or None once no more will come. Its
# arguments: whether to wait for a job (the lanes have nothing to do until it answers), and
# the most jobs the stream takes now (its free lanes and a reserve: the rest stay with the
# caller, where another device's stream of the same key can take them; before, the first
# stream took every waiting job and a second GPU stepped 3,537 of the FR3 sweep's 16,866
# stream-steps, 2026-11-27); it may answer an empty list (a timeout), and is asked again.
Source = Callable[[bool, int], "list[tuple[Hashable, DeviceJob]] | None"]
# Called with each job's key and outcome as soon as it is judged.
OnOutcome = Callable[[Hashable, PickOutcome], None]


@dataclass
class _Done:
    key: Hashable
    job: DeviceJob
    slot: int
    rows: np.ndarray
    warm: np.ndarray


@dataclass
class _Tugged:
    """A group whose tug ran: to judge on the host."""

    group: list[_Done]
    windows: dict[int, HoldWindow | None]
    rungs: dict[int, dict[Rung, RungOutcome]]
    overflowed: set[int]  # slots whose rungs did not fit even the large buffers


class LaneStream:
    """One task model's jobs through ``nlane`` lanes on ``batch``'s device, slot and buffers."""

    def __init__(
        self,
        batch: WorldBatch,
        nlane: int,
        group: int = TUG_GROUP,
        on_outcome: OnOutcome | None = None,
    ) -> None:
        self.batch, self.nlane, self.group = batch, nlane, group
        self.on_outcome = on_outcome
        self.timings = batch.timings
        self.lanes: LaneRun | None = None
        self.outcomes: dict[Hashable, PickOutcome] = {}
        self._slot_job: dict[int, tuple[Hashable, DeviceJob]] = {}
        self._free_slots: list[int] = []
        self._lockstep: list[tuple[Hashable, DeviceJob]] = []  # too long for a slot
        self._rerun: list[tuple[Hashable, DeviceJob]] = []  # did not fit the buffers
        # the tug rounds: their own thread, batch and device stream (made in ``run``)
        self._tug_batch: WorldBatch | None = None
        self._tugs: list[tuple[Future[_Tugged], list[int]]] = []  # in flight, with their slots
        self.wall_s = 0.0  # the last ``run``'s wall time
        # at each visit: (seconds into the run, busy lanes, jobs queued here, free job slots)
        self.trace: list[tuple[float, int, int, int]] = []
        # queue each replay before collecting the last (``HARNESS_LANE_AHEAD=1``; not yet
        # measured on a GPU: off by default)
        self.ahead = env_flag(AHEAD_ENV)
        # the rungs in the lanes (``lane_tug``), each job's ladder at its own pace (made with
        # the lanes, ``_make``; None: the tug runs beside the lanes)
        self.ladders: LaneLadders | None = None
        self._rung_steps = 0  # a rung's physics steps (with ladders)
        self._laddered: list[_Tugged] = []  # jobs whose ladder ended: to judge

    def run(self, source: Source) -> dict[Hashable, PickOutcome]:
        """Every job ``source`` gives, by key, once it gives ``None``."""
        started = self._started = time.perf_counter()
        try:
            return self._run(source)
        finally:
            self.wall_s = time.perf_counter() - started

    def _run(self, source: Source) -> dict[Hashable, PickOutcome]:
        with ThreadPoolExecutor(1, thread_name_prefix="mjwarp-tug") as tugger:
            self._tugger = tugger
            with self.batch.slot, wp.ScopedDevice(self.batch.dm.device):
                batch = self.batch
                slot = DeviceSlot.several(batch.dm.device, 1)[0]
                self._tug_batch = WorldBatch(batch.dm, batch.policy, batch.buffers, slot)
                try:
                    self._loop(source)
                    self._finish_lockstep()
                finally:
                    self._tugs_done(wait_all=True)
                    self._merge(self._tug_batch)
                    if self.ladders is not None:
                        self.timings.tug_rounds += self.ladders.rounds
        return self.outcomes

    def _make(self, job: DeviceJob) -> LaneRun:
        schedule = job.schedule
        window = window_steps(job.task.pick.hold_time, schedule.control_dt)
        substeps = sum(schedule.chunk_sizes)
        capacity = 2 * self.nlane + self.group
        if tug_in_lanes(self.ahead):
            self.ladders = LaneLadders(self.batch.dm.weight, self.batch.policy)
            self._rung_steps = rung_physics_steps(self.batch.dm, float(job.task.control_dt))
        self._free_slots = list(range(capacity - 1, -1, -1))
        return LaneRun(
            self.batch.dm, self.nlane, capacity, LANE_ROWS, window, schedule.chunk_sizes,
            self.batch.buffers, lambda n: self.batch.data(n, self.batch.buffers),
            (env_int("HARNESS_LANE_INTERVAL") or INTERVAL_CONTROL_STEPS) * substeps,
            rungs=self.ladders is not None,
        )  # fmt: skip

    def _loop(self, source: Source) -> None:
        pending: deque[tuple[Hashable, DeviceJob]] = deque()
        group: list[_Done] = []
        group_since = 0.0  # when the group's first job finished
        tugged: list[_Tugged] = []  # judged on the host while the device steps
        closed, replay_s = False, 0.0
        while True:
            lanes = self.lanes
            idle = lanes is None or not self._stepping(lanes)
            if not closed:
                if idle and not pending:
                    self._judge(tugged)  # nothing else to do until the source answers
                    # jobs too long for a slot or whose buffers overflowed: their callers wait
                    # for them (a product stream ends only when its run does)
                    self._finish_lockstep()
                block = idle and not pending
                room = self._room(pending)
                if block:  # the other streams of the device issue theirs meanwhile
                    with self.batch.slot.released():
                        new = source(True, room)
                else:
                    new = source(False, room)
                closed = new is None
                pending.extend(new or [])
            if self.lanes is None and pending:
                self.lanes = self._make(pending[0][1])
            lanes = self.lanes
            if lanes is not None:
                self._fill_rungs(lanes)
                self._fill(lanes, pending)
                if self._stepping(lanes):
                    done, replay_s = self._replay(lanes, tugged, replay_s)
                    now = time.perf_counter() - self._started
                    self.trace.append((now, lanes.busy, len(pending), len(self._free_slots)))
                    if self.ladders is not None:
                        self._start_ladders(lanes, done)
                        tugged += self._laddered
                        self._laddered = []
                    else:
                        if done and not group:
                            group_since = time.perf_counter()
                        group += done
            drained = closed and not pending and (lanes is None or not self._stepping(lanes))
            drained = drained and (self.ladders is None or not self.ladders.open)
            if group and (
                len(group) >= self.group
                or drained
                or len(group) >= (lanes.busy if lanes is not None else 0)
                or time.perf_counter() - group_since > GROUP_WAIT_S
            ):
                assert lanes is not None
                self._tug(lanes, group)
                group = []
            tugged += self._tugs_done(wait_all=drained or (idle and closed))
            if drained and not group and not self._tugs:
                self._judge(tugged)
                return

    def _room(self, pending: deque[tuple[Hashable, DeviceJob]]) -> int:
        """The most jobs to take from the source now: the free lanes and a quarter of the
        lanes in reserve (loaded at the next visit), less those already waiting here."""
        free = self.nlane if self.lanes is None else len(self.lanes.free_lanes())
        return max(0, free + self.nlane // 4 - len(pending))

    def _stepping(self, lanes: LaneRun) -> bool:
        """A lane holds a job or a rung, a rung waits for a lane, or (ahead) a replay or
        download is not yet collected."""
        queued = self.ladders is not None and bool(self.ladders.queue)
        return lanes.busy > 0 or queued or (self.ahead and lanes.in_flight)

    def _replay(
        self, lanes: LaneRun, tugged: list[_Tugged], last_s: float
    ) -> tuple[list[_Done], float]:
        """One host visit: queue a replay of the lanes, judge on the host meanwhile (for at
        most half the last visit), wait for the device, collect the finished jobs. Ahead
        (``LaneRun.queue`` / ``settle``) the wait is for the previous visit's replay, so the
        device steps on while the host collects, loads and judges."""
        slot = self.batch.slot
        clock = time.perf_counter()
        if self.ahead:
            lanes.queue(self.timings, slot.launch)
        else:
            lanes.launch(self.timings, slot.launch)
        launched = time.perf_counter()
        self._judge(tugged, 0.5 * last_s)
        judged = time.perf_counter()
        if self.ahead:
            finished = lanes.settle(self.timings, slot.wait_mark, slot.mark)
        else:
            slot.wait()
            finished = None
        end = time.perf_counter()
        self._visit(launched - clock, end - judged, end - clock)
        return self._collect(lanes, finished), end - clock

    def _visit(self, launch_s: float, wait_s: float, replay_s: float) -> None:
        t = self.timings
        t.visits += 1
        t.launch_s += launch_s
        t.wait_s += wait_s
        t.physics_s += replay_s

    def summary(self) -> str:
        """One line on this stream's device work: its physics steps, their wall time per step
        (a replay's launch, judging meanwhile, and the wait for the stream), how much of that
        was the launch and the wait, and the host's other work (the stream's wall less its
        physics: the source, uploads, downloads, the lockstep leftovers)."""
        t = self.timings
        steps = t.motion_steps // max(1, self.nlane)
        per_step = 1000.0 * t.physics_s / max(1, steps)
        return (
            f"{self.wall_s:.1f} s, {self.nlane} lanes, {steps:,} physics steps in {t.visits} "
            f"visits: {per_step:.2f} ms a step (launch {t.launch_s:.1f} s, wait "
            f"{t.wait_s:.1f} s of {t.physics_s:.1f} s), upload {t.upload_s:.1f} s, "
            f"download {t.download_s:.1f} s, judge {t.judge_s:.1f} s, "
            + self._tug_summary()
            + (f", {t.loop_graphs} graph(s) as device loops" if t.loop_graphs else "")
            + occupancy(self.trace, self.wall_s)
        )

    def _tug_summary(self) -> str:
        t = self.timings
        if self.ladders is not None:
            return f"tug in the lanes: {t.tug_rungs} rungs, {t.tug_rounds} ladder round(s)"
        return f"tug {t.tug_s:.1f} s in {t.tug_rounds} round(s)"

    def _fill_rungs(self, lanes: LaneRun) -> None:
        """Load queued tug rungs into free lanes (before new jobs: a rung frees its job's slot
        sooner)."""
        if self.ladders is None or not self.ladders.queue:
            return
        free = lanes.free_lanes()
        requests = self.ladders.take(len(free))
        if not requests:
            return
        clock = time.perf_counter()
        lanes.load_rungs(
            free[: len(requests)],
            np.array([r.tag for r in requests], dtype=np.int64),
            np.array([r.slot for r in requests], dtype=np.int64),
            np.array([r.saved for r in requests], dtype=np.int64),
            np.array([r.force for r in requests], dtype=np.float64),
            self._rung_steps,
        )
        self.timings.upload_s += time.perf_counter() - clock

    def _start_ladders(self, lanes: LaneRun, done: list[_Done]) -> None:
        """The finished jobs: those the validity phase tugs open their ladders (their rungs
        queue for the lanes); the others are ready to judge, their slots freed."""
        if not done:
            return
        assert self.ladders is not None
        jobs = [item.job for item in done]
        slots = [item.slot for item in done]
        validity = [validity_enabled(job.task.pick) for job in jobs]
        windows, tugged = hold_windows(jobs, slots, {i.slot: i.rows for i in done}, validity, set())
        laddered = set(tugged)
        plain = [item for item in done if item.slot not in laddered]
        if plain:
            self._laddered.append(_Tugged(plain, windows, {}, set()))
            self._release(lanes, [item.slot for item in plain])
        for item in done:
            window = windows[item.slot]
            if item.slot in laddered and window is not None:
                motion = int(lanes.motion_host[item.slot])
                self.ladders.start(item, item.slot, window, item.rows, motion)

    def _rungs_ended(self, lanes: LaneRun, rungs: RungsFinished) -> None:
        """Rungs back from the lanes: complete ladders are ready to judge; a ladder whose rung
        did not fit the buffers reruns its job whole (lockstep on ``LARGE``, which tugs it
        there), as a rung round that did not fit even ``LARGE`` does."""
        assert self.ladders is not None
        complete, dropped = self.ladders.ended(rungs.tags, rungs.rows, rungs.overflowed)
        ended: list[Ladder] = complete + dropped
        for ladder in complete:
            item = ladder.item
            self._laddered.append(
                _Tugged([item], {item.slot: ladder.window}, {item.slot: ladder.known}, set())
            )
        for ladder in dropped:
            self._rerun.append((ladder.item.key, ladder.item.job))
        if ended:
            self._release(lanes, [ladder.slot for ladder in ended])

    def _fill(self, lanes: LaneRun, pending: deque[tuple[Hashable, DeviceJob]]) -> None:
        free = lanes.free_lanes()
        take: list[tuple[Hashable, DeviceJob]] = []
        while pending and len(take) < min(len(free), len(self._free_slots)):
            key, job = pending.popleft()
            if self._span(job) > LANE_ROWS:
                self._lockstep.append((key, job))
            else:
                take.append((key, job))
        if not take:
            return
        clock = time.perf_counter()
        slots = np.array([self._free_slots.pop() for _ in take], dtype=np.int64)
        for slot, item in zip(slots, take, strict=True):
            self._slot_job[int(slot)] = item
        jobs = [job for _, job in take]
        lanes.load(free[: len(take)], slots, jobs, np.array([self._span(job) for job in jobs]))
        self.timings.upload_s += time.perf_counter() - clock

    @staticmethod
    def _span(job: DeviceJob) -> int:
        window = window_steps(job.task.pick.hold_time, job.schedule.control_dt)
        return job.schedule.steps + (window if validity_enabled(job.task.pick) else 0)

    def _collect(self, lanes: LaneRun, finished: Finished | None = None) -> list[_Done]:
        """The finished jobs (``finished``, else downloaded now): overflowed ones are set
        aside for a rerun and their slots freed."""
        if finished is None:
            clock = time.perf_counter()
            finished = lanes.collect(self.timings)
            self.timings.download_s += time.perf_counter() - clock
        if finished.rungs is not None:
            self._rungs_ended(lanes, finished.rungs)
        done = []
        for slot, rows, warm, over in zip(
            finished.slots, finished.rows, finished.warm, finished.overflowed, strict=True
        ):
            key, job = self._slot_job.pop(slot)
            if over:
                self._rerun.append((key, job))
                self._release(lanes, [slot])
            else:
                done.append(_Done(key, job, slot, rows, warm))
        return done

    def _release(self, lanes: LaneRun, slots: list[int]) -> None:
        lanes.release(slots)
        self._free_slots.extend(slots)

    def _tug(self, lanes: LaneRun, group: list[_Done]) -> None:
        """Start the group's tug ladders in the tug thread; its slots are freed when they are
        done (``_tugs_done``): the rungs start from the slots' saved states."""
        jobs = [item.job for item in group]
        slots = [item.slot for item in group]
        rows = {item.slot: item.rows for item in group}
        validity = [validity_enabled(job.task.pick) for job in jobs]
        windows, tugged = hold_windows(jobs, slots, rows, validity, set())
        arms = {item.slot: item.job.task.arm for item in group}
        start = RungStart(jobs, lanes.saved, lanes.hold_ctrl, lanes.mocap, lanes.motion_host,
                           windows, arms)  # fmt: skip
        batch = self._tug_batch
        assert batch is not None

        def run() -> _Tugged:
            with batch.slot, wp.ScopedDevice(batch.dm.device):
                rungs, over = batch.tug(start, rows, tugged)
            return _Tugged(group, windows, rungs, over)

        self._tugs.append((self._tugger.submit(run), slots))

    def _tugs_done(self, wait_all: bool = False) -> list[_Tugged]:
        """The tug groups whose ladders are done (all of them with ``wait_all``: waited for with
        the host lock let go), their slots freed; a failed tug raises here."""
        if wait_all and self._tugs:
            with self.batch.slot.released():
                wait([future for future, _ in self._tugs])
        done, running = [], []
        for future, slots in self._tugs:
            (done if future.done() else running).append((future, slots))
        self._tugs = running
        finished = []
        for future, slots in done:
            finished.append(future.result())
            if self.lanes is not None:
                self._release(self.lanes, slots)
        return finished

    def _judge(self, ready: list[_Tugged], budget_s: float = math.inf) -> None:
        """Judge the tugged groups' jobs on the host, for at most about ``budget_s`` (the rest
        stays in ``ready`` for the next call: a large group is judged over several replays)."""
        if ready:  # host work only: the other streams of the device issue theirs meanwhile
            with self.batch.slot.released():
                self._judge_ready(ready, budget_s)

    def _judge_ready(self, ready: list[_Tugged], budget_s: float) -> None:
        clock = time.perf_counter()
        while ready and time.perf_counter() - clock < budget_s:
            tugged = ready[0]
            item = tugged.group.pop()
            if not tugged.group:
                ready.pop(0)
            if item.slot in tugged.overflowed:
                self._rerun.append((item.key, item.job))
                continue
            validity = validity_enabled(item.job.task.pick)
            self._done(item.key, judge_started(
                item.job, item.rows, item.warm, validity, tugged.windows[item.slot],
                tugged.rungs.get(item.slot),
            ))  # fmt: skip
        self.timings.judge_s += time.perf_counter() - clock

    def _done(self, key: Hashable, outcome: PickOutcome) -> None:
        self.outcomes[key] = outcome
        if self.on_outcome is not None:
            self.on_outcome(key, outcome)

    def _finish_lockstep(self) -> None:
        """The jobs too long for a slot (lockstep on the stream's buffers), and those that did
        not fit them (lockstep on ``LARGE``, as a lockstep batch reruns its overflowed worlds);
        each list is emptied as it runs."""
        if self._lockstep:
            items, self._lockstep = self._lockstep, []
            outcomes = self.batch.run_held([job for _, job in items])
            for (key, _), outcome in zip(items, outcomes, strict=True):
                self._done(key, outcome)
        if self._rerun:
            items, self._rerun = self._rerun, []
            large = WorldBatch(self.batch.dm, buffers=LARGE, slot=self.batch.slot)
            self.timings.reruns += len(items)
            outcomes = large.run_held([job for _, job in items])
            for (key, _), outcome in zip(items, outcomes, strict=True):
                self._done(key, outcome)
            self._merge(large)

    def _merge(self, batch: WorldBatch) -> None:
        add_timings(self.timings, batch.timings)
