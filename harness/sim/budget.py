"""An episode's limits: a wall-clock deadline and a budget of simulated physics steps.

An unattended sweep must never hang on one episode (a ``physics.timestep`` of 1e-9 s asks for
billions of steps; a pathological plan can loop). ``episode_budget`` sets both limits for the
episode that runs inside it; every ``Scene.step`` spends from the budget (``spend``) and checks
the deadline, so a long ``mj_step`` burst is refused before it starts. In the main thread a
SIGALRM timer is the backstop for work that never steps the physics (planning). Past either
limit an ``EpisodeTimeoutError`` ends the episode, which ``run_episode`` stores as ``timeout``
with the facts gathered so far. Outside ``episode_budget`` nothing is limited.
"""

from __future__ import annotations

import contextlib
import signal
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass

from harness.errors import EpisodeTimeoutError


@dataclass
class _Budget:
    deadline: float
    wall_time_s: float
    steps_left: int
    sim_steps: int


class _Stacks(threading.local):
    """Each thread's own stack of budgets: episodes run in threads are each limited by their
    own."""

    def __init__(self) -> None:
        self.stack: list[_Budget] = []


_STACKS = _Stacks()


def _active() -> list[_Budget]:
    return _STACKS.stack


def spend(nstep: int) -> None:
    """Take ``nstep`` physics steps from the active budget, or end the episode as a timeout."""
    active = _active()
    if not active:
        return
    budget = active[-1]
    if nstep > budget.steps_left:
        used = budget.sim_steps - budget.steps_left
        raise EpisodeTimeoutError(
            f"simulated-step budget of {budget.sim_steps:,} steps reached ({used:,} used, "
            f"{nstep:,} more asked); raise limits.sim_steps or use a larger physics.timestep"
        )
    check_deadline()
    budget.steps_left -= nstep


def check_deadline() -> None:
    """End the episode as a timeout once the active budget's wall-clock deadline has passed."""
    active = _active()
    if active and time.perf_counter() > active[-1].deadline:
        budget = active[-1]
        used = budget.sim_steps - budget.steps_left
        raise EpisodeTimeoutError(
            f"wall-clock limit of {budget.wall_time_s:g} s reached after {used:,} physics "
            f"steps; raise limits.wall_time_s if the episode is expected to be this slow"
        )


@contextlib.contextmanager
def episode_budget(wall_time_s: float, sim_steps: int) -> Iterator[None]:
    """Limit the episode run inside: ``wall_time_s`` of wall clock, ``sim_steps`` physics steps."""
    budget = _Budget(time.perf_counter() + wall_time_s, wall_time_s, sim_steps, sim_steps)
    active = _active()
    active.append(budget)
    alarm = threading.current_thread() is threading.main_thread() and hasattr(signal, "SIGALRM")
    previous = None
    if alarm:

        def on_alarm(signum: int, frame: object) -> None:
            check_deadline()

        previous = signal.signal(signal.SIGALRM, on_alarm)
        # A little after the deadline, so the cooperative check usually ends the episode first.
        signal.setitimer(signal.ITIMER_REAL, wall_time_s + 0.05, 0.5)
    try:
        yield
    finally:
        if alarm:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, previous or signal.SIG_DFL)
        active.pop()
