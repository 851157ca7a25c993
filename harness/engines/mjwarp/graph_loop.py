"""A run of physics steps as one CUDA graph whose loop runs on the device (a conditional
WHILE node), instead of a graph with every step's kernels unrolled.

A lane stream's visit replays ``interval`` physics steps (136 for the FR3 cube: 8 control steps
of 17) and a tug round ~250 more. Unrolled, that graph holds ~150 kernel nodes a step, ~20,000
a visit, and the host's launch returns only when most of it has run (a sampling profile of the
demo, 2026-11-27: 53-74% of a lone 64-lane stream's time inside ``capture_launch``); ten demo
streams at once share ~650-860 stream-steps a second, whatever their lanes, as if the launches,
not the device, set the pace. Here the graph holds one step's kernels inside a WHILE node
(CUDA 12.4+, NVIDIA's "Dynamic Control Flow in CUDA Graphs with Conditional Nodes"; MuJoCo Warp
already nests its solver loop in one, ``wp.capture_while``): a kernel sets a device counter to
the step count, the body steps once and counts down, and the device repeats it with no host
work per step. The kernels and their order are the unrolled graph's.

A conditional body may hold kernels, memsets, copies and conditionals, not allocations, and
MuJoCo Warp allocates ~47 scratch arrays a step (``wp.empty`` / ``wp.zeros`` of its collision,
constraint and solver contexts; the first try on an H200, 2026-11-28: "Conditional body graph
contains an unsupported operation (memory allocation)"). So one eager step runs first with a
``StepArena`` as the device's allocator, which keeps every block that step asked for; inside
the body the arena hands the same blocks out again in the same order (a zeroed array still
gets its memset), so the body allocates nothing. A step's scratch lives only within the step,
so the steps of the loop reuse it one after another on one stream.

``HARNESS_GRAPH_LOOP=1`` turns it on for the lanes' visits and the tug rounds. Default off: on an
H200 (2026-11-28, docs/engines.md) ten bare 128-world streams ran 3.1x faster looped, but the
demo and the FR3 sweep kept their walls (76.8 s against 81.5 s, 49.4 s against 49.5 s): the
loop took two thirds of the launch time off the host, and the product's streams then waited
that much longer for the device, which was the bound. On Warp's CPU device nothing is
captured: ``loop_steps`` runs the same loop eagerly (the host reads the counter every turn, the
arena swapped in for the CPU allocator), which is how it is tested.
"""

from __future__ import annotations

import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import warp as wp

from harness.engines.mjwarp.lane_sizes import env_flag

LOOP_ENV = "HARNESS_GRAPH_LOOP"


# Why this process stopped capturing loops: the first capture that failed (empty: none has).
_failed: list[str] = []


def graph_loop() -> bool:
    """Whether runs of physics steps are captured as device loops (``HARNESS_GRAPH_LOOP``: 1 or
    0; default 0), unless a capture failed in this process (``try_loop_steps``)."""
    return env_flag(LOOP_ENV) and not _failed


@wp.kernel
def set_count(left: wp.array(dtype=wp.int32), count: wp.int32):  # type: ignore[valid-type]
    left[0] = count


@wp.kernel
def count_down(left: wp.array(dtype=wp.int32)):  # type: ignore[valid-type]
    left[0] = left[0] - 1


class ArenaMismatchError(RuntimeError):
    """A step asked for other blocks than the step the arena recorded."""


class StepArena:
    """A Warp allocator that records the blocks of one step (through ``base``) and then, while
    ``armed``, hands the same blocks out again in the same order; freeing one of its blocks is
    a no-op until ``free``. Unarmed after recording, it passes requests through to ``base``.

    A device's allocator is the device's, not a thread's, and other threads allocate on it
    meanwhile (``prewarm`` builds the next task model's arrays beside the streams): only the
    thread that made the arena is served from it; the others' requests go to ``base``."""

    def __init__(self, base: Any) -> None:
        self.base = base
        self.owner = threading.get_ident()
        self.memory_kind = getattr(base, "memory_kind", None)
        self.deallocate_requires_context_guard = getattr(
            base, "deallocate_requires_context_guard", True
        )
        self.blocks: list[tuple[int, int]] = []
        self.owned: set[int] = set()
        self.given_back: set[int] = set()
        self.recording = True
        self.armed = False
        self.next = 0

    def allocate(self, size_in_bytes: int) -> int:
        if threading.get_ident() != self.owner:
            return int(self.base.allocate(size_in_bytes))
        if self.recording:
            ptr = int(self.base.allocate(size_in_bytes))
            self.blocks.append((ptr, size_in_bytes))
            self.owned.add(ptr)
            return ptr
        if not self.armed:
            return int(self.base.allocate(size_in_bytes))
        if self.next >= len(self.blocks) or self.blocks[self.next][1] != size_in_bytes:
            raise ArenaMismatchError(
                f"step allocation {self.next} asks {size_in_bytes} bytes; the recorded step "
                f"made {len(self.blocks)} blocks"
            )
        ptr = self.blocks[self.next][0]
        self.next += 1
        return ptr

    def deallocate(self, ptr: int, size_in_bytes: int) -> None:
        # a block of the arena goes back with ``free`` only, once: an array of the recorded
        # step that outlives it (none should) must not free its block a second time
        if ptr not in self.owned and ptr not in self.given_back:
            self.base.deallocate(ptr, size_in_bytes)

    def free(self) -> None:
        """Give every recorded block back (its step's work must be done or ordered before)."""
        for ptr, size in self.blocks:
            self.base.deallocate(ptr, size)
        self.given_back |= self.owned
        self.blocks, self.owned = [], set()


@contextmanager
def installed(device: str, allocator: Any) -> Iterator[None]:
    """``allocator`` as ``device``'s allocator meanwhile: Warp's ``ScopedAllocator`` on a CUDA
    device; on Warp's CPU device (custom allocators are CUDA-only) its default allocator is
    swapped, so that the arena can be tested there."""
    dev = wp.get_device(device)
    if dev.is_cuda:
        with wp.ScopedAllocator(dev, allocator):
            yield
        return
    saved = dev.default_allocator
    dev.default_allocator = allocator
    try:
        yield
    finally:
        dev.default_allocator = saved


@dataclass
class LoopGraph:
    """A captured graph that runs a step a set number of times on the device, its counter and its
    steps' scratch (kept alive with it: the graph reads and writes them; the scratch is given
    back when this is dropped, after its last launch has run)."""

    graph: Any
    left: wp.array
    arena: StepArena

    def __del__(self) -> None:
        self.arena.free()


def run_loop(device: str, step: Callable[[], None], times: int, left: wp.array) -> None:
    """Issue ``times`` calls of ``step`` as a WHILE loop on ``left`` (captured: a conditional
    node; eager: the host reads ``left`` before every turn)."""
    wp.launch(set_count, dim=1, inputs=[left, times], device=device)

    def body() -> None:
        step()
        wp.launch(count_down, dim=1, inputs=[left], device=device)

    wp.capture_while(left, body)


def loop_steps(
    device: str, step: Callable[[], None], times: int, capture: bool = True
) -> LoopGraph | None:
    """Run ``step`` once now, recording its allocations in a ``StepArena``, then ``times`` more
    steps as a WHILE loop whose body takes its scratch from the arena: captured on a CUDA
    ``device`` (returned: one launch runs the ``times`` steps; ``step``'s kernels must be
    loaded, one eager call before), or with ``capture`` False run eagerly now (None)."""
    arena = StepArena(wp.get_device(device).get_allocator())
    with installed(device, arena):
        step()
    arena.recording = False
    left = wp.zeros(1, dtype=wp.int32, device=device)

    def step_from_arena() -> None:
        arena.armed, arena.next = True, 0
        try:
            step()
        finally:
            arena.armed = False

    try:
        with installed(device, arena):
            if not capture:
                run_loop(device, step_from_arena, times, left)
                arena.free()
                return None
            with wp.ScopedCapture(device=device) as recorded:
                run_loop(device, step_from_arena, times, left)
    except BaseException:
        wp.synchronize_device(device)  # the recording step's work, before its scratch goes
        arena.free()
        raise
    assert recorded.graph is not None
    return LoopGraph(recorded.graph, left, arena)


def try_loop_steps(device: str, step: Callable[[], None], times: int) -> LoopGraph | None:
    """``loop_steps`` captured, or None (its recording step ran) where the capture failed: the
    process then says why once, on stderr, and captures unrolled graphs from then on
    (``graph_loop`` is False), so a device or driver without the loop's needs costs a warning,
    not the run's rows."""
    try:
        return loop_steps(device, step, times)
    except Exception as error:  # the capture's own failure, whatever Warp or CUDA raises
        if not _failed:
            _failed.append(f"{type(error).__name__}: {error}")
            print(
                f"mjwarp: {LOOP_ENV}=1 but the device loop could not be captured on {device} "
                f"({_failed[0]}); capturing unrolled graphs instead",
                file=sys.stderr,
                flush=True,
            )
        return None
