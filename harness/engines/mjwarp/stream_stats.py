"""What a run's lane streams did (``StreamStats``): jobs, streams, lanes, device time, first-use
compiles, failures, and where the streams' host time went (their ``BatchTimings`` summed)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Any


@dataclass
class StreamStats:
    """What the devices did: jobs, lane streams run, the most lanes of one, seconds with a
    stream on a device (the union over devices), streams per device, the first-use compile
    (s) per (device, key), failures, the most streams in flight on one device at once."""

    jobs: int = 0
    streams: int = 0
    lanes: int = 0
    device_s: float = 0.0
    by_device: dict[str, int] = field(default_factory=dict)
    jobs_by_device: dict[str, int] = field(default_factory=dict)  # jobs answered on each
    compile_s: dict[str, float] = field(default_factory=dict)
    errors: list[str] = field(default_factory=list)
    timings: Any = None  # the streams' BatchTimings, summed (bench figures)
    concurrent: int = 0

    def spread(self) -> str:
        """With several devices, the streams and jobs each ran, e.g. `` (cuda:0: 1 stream(s),
        10,240 job(s); cuda:1: 1 stream(s), 844 job(s))``; '' with one (an uneven split shows
        here: on two H200s one GPU took 10,240 of 11,084 jobs, 2026-11-28)."""
        if len(self.by_device) < 2:
            return ""
        parts = [
            f"{name}: {n} stream(s), {self.jobs_by_device.get(name, 0):,} job(s)"
            for name, n in sorted(self.by_device.items())
        ]
        return " (" + "; ".join(parts) + ")"

    def breakdown(self) -> str:
        """Where the streams' host time went (summed over streams, so it can exceed the wall),
        and how much of the lanes' stepping was busy (within a job's span, or a tug rung run in
        a lane)."""
        t = self.timings
        if t is None:
            return ""
        busy = t.span_steps / t.motion_steps if t.motion_steps else 0.0
        return (
            f"streams' time: physics {t.physics_s:.1f} s, tug {t.tug_s:.1f} s (issuing "
            f"{t.tug_issue_s:.1f} s; {t.tug_rounds} round(s), {t.tug_rungs} rung-world(s)), "
            f"upload {t.upload_s:.1f} s, "
            f"download {t.download_s:.1f} s, judge {t.judge_s:.1f} s; lanes busy (a job's "
            f"span or a rung) {100 * busy:.0f}% of {t.motion_steps:,} lane-steps"
            + (f"; {t.loop_graphs} graph(s) as device loops" if t.loop_graphs else "")
        )

    # the names the sweep's summary line reads (it predates lane streams)
    @property
    def batches(self) -> int:
        return self.streams

    @property
    def largest(self) -> int:
        return self.lanes


def add_timings(total: Any, more: Any) -> None:
    """Add the counts of ``more`` (``BatchTimings``) to ``total``; keep the larger peaks."""
    for item in fields(total):
        mine, theirs = getattr(total, item.name), getattr(more, item.name)
        combined = max(mine, theirs) if item.name.startswith("peak_") else mine + theirs
        setattr(total, item.name, combined)


def add_side_by_side(total: StreamStats, more: StreamStats) -> None:
    """Add the stats of devices that ran at the same time as ``total``'s (a process per device):
    counts, lists and timings summed; lanes and streams at once, the larger; device seconds,
    the longer (the union of spans is not known across processes)."""
    total.jobs += more.jobs
    total.streams += more.streams
    total.lanes = max(total.lanes, more.lanes)
    total.concurrent = max(total.concurrent, more.concurrent)
    total.device_s = max(total.device_s, more.device_s)
    for name, count in more.by_device.items():
        total.by_device[name] = total.by_device.get(name, 0) + count
    for name, count in more.jobs_by_device.items():
        total.jobs_by_device[name] = total.jobs_by_device.get(name, 0) + count
    total.compile_s.update(more.compile_s)
    total.errors.extend(more.errors)
    if more.timings is not None:
        if total.timings is None:
            total.timings = more.timings
        else:
            add_timings(total.timings, more.timings)


def occupancy(trace: list[tuple[float, int, int, int]], wall_s: float) -> str:
    """Where a stream's lanes idled: at the first visit of each tenth of its wall time, its
    busy lanes, the jobs queued for it and its free job slots (a job keeps its slot until
    its tug is done), e.g. ``; by tenths, busy/queued/free slots: 8192/2048/0 ...``."""
    if not trace or wall_s <= 0:
        return ""
    marks, tenth = [], 0
    for at, busy, queued, free in trace:
        if at >= tenth * wall_s / 10:
            marks.append(f"{busy}/{queued}/{free}")
            tenth = math.floor(10 * at / wall_s) + 1
    return "; by tenths, busy/queued/free slots: " + " ".join(marks)
