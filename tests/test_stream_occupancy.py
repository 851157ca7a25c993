"""A lane stream's line says where its lanes idled: busy lanes, queued jobs and free job slots
at the first visit of each tenth of its wall time (no device needed: the trace alone)."""

from __future__ import annotations

from harness.engines.mjwarp.stream_stats import occupancy


def test_one_mark_a_tenth_from_the_first_visit_past_it() -> None:
    # a 10 s stream visited every 0.5 s: full lanes for 6 s, then a tail with nothing queued
    trace = [(0.5 * i, 8 if i < 12 else 8 - (i - 11), 4 if i < 12 else 0, 2) for i in range(20)]
    line = occupancy(trace, 10.0)
    marks = line.removeprefix("; by tenths, busy/queued/free slots: ").split()
    assert len(marks) == 10
    assert marks[0] == "8/4/2" and marks[5] == "8/4/2"  # at 0 s and 5 s
    assert marks[6] == "7/0/2" and marks[9] == "1/0/2"  # at 6 s and 9 s: lanes idle, no jobs


def test_sparse_visits_skip_the_tenths_they_missed() -> None:
    # one visit at 0.1 s, the next at 7.5 s of a 10 s stream: two marks, not ten
    assert occupancy([(0.1, 4, 0, 1), (7.5, 2, 0, 3)], 10.0).endswith(": 4/0/1 2/0/3")


def test_no_visit_no_line() -> None:
    assert occupancy([], 5.0) == "" and occupancy([(0.0, 1, 0, 0)], 0.0) == ""
