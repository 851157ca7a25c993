"""A run's pace: rows between the 10% and 90% arrivals over their time, and rows by tenths."""

from __future__ import annotations

import pytest

from harness.runs.pace import MIN_ROWS, Arrivals, pace_line, pace_of


def test_the_steady_rate_leaves_out_the_start_and_the_tail() -> None:
    # 20 s of start-up with nothing, then 1,000 rows at 100 a second, then a 30 s tail of 10
    arrivals = [20.0 + k / 100 for k in range(1000)] + [30.0 + 3.0 * k for k in range(1, 11)]
    pace = pace_of(arrivals, 60.0)
    assert pace is not None
    assert pace.rows == 807  # the rows after arrival 101 up to arrival 908 of 1,010
    assert pace.per_hour == pytest.approx(360_000, rel=1e-9)  # 100 rows a second
    # rows by the end of each 6 s: none before 20 s, all 1,000 of the stream by 30 s
    assert pace.tenths[:5] == [0, 0, 0, 401, 1000]
    assert pace.tenths[-1] == 1010


def test_the_line_names_rate_and_tenths() -> None:
    arrivals = [float(k) for k in range(1, 201)]  # 200 rows, one a second
    line = pace_line(arrivals, 200.0)
    assert line is not None
    assert line.startswith("pace: 159 rows (10%-90% arrivals) in 159.0 s = 3,600 episodes/h")
    assert line.endswith("rows by tenths of the wall: 20 40 60 80 100 120 140 160 180 200")


def test_too_few_rows_no_line() -> None:
    assert pace_line([1.0] * (MIN_ROWS - 1), 10.0) is None
    # a run whose executor stopped its clock before its last row: the wall is that row's
    assert pace_of([float(k) for k in range(MIN_ROWS)], 5.0) is not None


def test_arrivals_count_from_their_making() -> None:
    arrivals = Arrivals()
    arrivals.mark()
    arrivals.mark()
    assert len(arrivals.times) == 2 and 0 <= arrivals.times[0] <= arrivals.times[1] < 5
