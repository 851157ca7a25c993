"""A sampling profiler of every thread of this process, for the GPU box (no py-spy there).

``cProfile`` sees one thread; the ``mjwarp`` engine's parent process runs a thread per lane
stream, the pool's receivers and the writer. Every ``interval_s`` a daemon thread takes
``sys._current_frames()`` and counts, per function (``file:line name``), the samples in which it
is on some thread's stack (inclusive) and at the top of one (self). Idle waits (``sleep``,
``wait``, ``select``, lock acquires) show up as such, so the busy share is what is left.

Started by ``harness`` when ``HARNESS_SAMPLE_PROFILE`` names a file: the table is written there
every 15 s and at exit; each device-pool worker (``--engine mjwarp``) writes its own beside it,
``FILE.worker-PID`` (where the planning's time goes).
"""

from __future__ import annotations

import atexit
import os
import sys
import threading
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path

ENV = "HARNESS_SAMPLE_PROFILE"


class Sampler:
    """Counts of functions on the stacks of every thread but its own, sampled."""

    def __init__(
        self,
        interval_s: float = 0.005,
        on_tick: Callable[[Sampler], None] | None = None,
        tick_s: float = 15.0,
    ) -> None:
        self.interval_s = interval_s
        self.inclusive: Counter[str] = Counter()
        self.own: Counter[str] = Counter()
        self.samples = 0
        self._stop = threading.Event()
        self._on_tick = on_tick
        self._tick_s = tick_s
        self._thread = threading.Thread(target=self._run, name="sampler", daemon=True)

    def start(self) -> Sampler:
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=1.0)

    def _run(self) -> None:
        me = threading.get_ident()
        last_tick = time.perf_counter()
        while not self._stop.wait(self.interval_s):
            if self._on_tick is not None and time.perf_counter() - last_tick > self._tick_s:
                last_tick = time.perf_counter()
                self._on_tick(self)
            for ident, frame in sys._current_frames().items():
                if ident == me:
                    continue
                self.samples += 1
                seen: set[str] = set()
                top = True
                node = frame
                while node is not None:
                    code = node.f_code
                    name = f"{Path(code.co_filename).name}:{code.co_firstlineno} {code.co_name}"
                    if top:
                        self.own[name] += 1
                        top = False
                    if name not in seen:
                        self.inclusive[name] += 1
                        seen.add(name)
                    node = node.f_back

    def table(self, top: int = 60) -> str:
        """The ``top`` functions by inclusive samples, with their self samples."""
        lines = [f"{self.samples} thread-samples every {self.interval_s * 1000:.1f} ms"]
        lines.append(f"{'inclusive':>9} {'self':>7}  function")
        for name, count in self.inclusive.most_common(top):
            lines.append(f"{count:>9} {self.own[name]:>7}  {name}")
        lines.append("")
        lines.append("by self samples:")
        for name, count in self.own.most_common(top // 2):
            lines.append(f"{count:>9}  {name}")
        return "\n".join(lines) + "\n"


def start_from_env(suffix: str = "") -> Callable[[], None]:
    """Start a sampler writing its table at exit to ``$HARNESS_SAMPLE_PROFILE`` plus
    ``suffix`` (if set; a device-pool worker's suffix names its process); returns what stops it
    and writes the table (nothing to stop when unset). A ``multiprocessing`` child ends without
    ``atexit``, so it calls that itself; the table is also written every 15 s."""
    target = os.environ.get(ENV)
    if not target:
        return lambda: None
    target += suffix
    clock = time.perf_counter()

    def dump(sampler: Sampler) -> None:
        from harness.writes import write_file

        try:
            wall = f"wall {time.perf_counter() - clock:.1f} s\n"
            write_file(target, wall + sampler.table())
        except Exception as exc:  # a profile must never stop the run it watches
            print(f"sampler: could not write {target}: {exc}", file=sys.stderr)

    sampler = Sampler(on_tick=dump).start()  # the table every 15 s, and at exit

    def at_exit() -> None:
        sampler.stop()
        dump(sampler)

    atexit.register(at_exit)
    return at_exit
