"""A tune's phase clock charges the time since the last lap to each phase, in order."""

from __future__ import annotations

import pytest

from harness.tuning import phase_clock
from harness.tuning.phase_clock import PhaseClock


def test_laps_in_order_and_the_total(monkeypatch: pytest.MonkeyPatch) -> None:
    now = iter([100.0, 146.0, 154.0, 368.0, 380.0, 700.0, 755.0])
    monkeypatch.setattr(phase_clock.time, "perf_counter", lambda: next(now))
    clock = PhaseClock()  # started at 100 s
    clock.lap("screen")  # 46 s
    clock.lap("screen report")  # 8 s
    clock.lap("refine")  # 214 s
    clock.lap("screen")  # a phase lapped again adds up: 46 + 12 s
    clock.lap("race")  # 320 s
    assert clock.phases == {"screen": 58.0, "screen report": 8.0, "refine": 214.0, "race": 320.0}
    assert (
        clock.line()
        == "time: screen 58 s, screen report 8 s, refine 214 s, race 320 s, 655 s in all"
    )
