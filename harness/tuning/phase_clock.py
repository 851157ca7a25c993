"""Where a tune's wall time went: seconds per named phase, in the order they ran.

Issue 34's target is a whole tune in under 10 minutes on one GPU, and a tune's progress lines
give only its episode passes (on an H100, 2026-11-28: screening 2 min 26 s, refinement 3 min
34 s and the race rounds 3 min 40 s of a 10 min 55 s tune, the other 75 s unaccounted for).
The clock laps each phase, reports and outputs included, and the tune prints one line.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field


@dataclass
class PhaseClock:
    """Laps: ``lap(name)`` charges the time since the last lap (or the start) to ``name``."""

    started: float = field(default_factory=lambda: time.perf_counter())
    phases: dict[str, float] = field(default_factory=dict)
    last: float = 0.0

    def __post_init__(self) -> None:
        self.last = self.started

    def lap(self, name: str) -> None:
        now = time.perf_counter()
        self.phases[name] = self.phases.get(name, 0.0) + now - self.last
        self.last = now

    def line(self) -> str:
        """``time: screen 146 s, screen report 8 s, refine 214 s, refine report 12 s, race and
        outputs 230 s, 655 s in all`` (a phase's name holds no comma)."""
        total = time.perf_counter() - self.started
        parts = [f"{name} {seconds:.0f} s" for name, seconds in self.phases.items()]
        return "time: " + ", ".join([*parts, f"{total:.0f} s in all"])
