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
work per step. The kernels and their order are the same as the unrolled graph's, so are the
states.

``HARNESS_GRAPH_LOOP=1`` turns it on for the lanes' visits and the tug rounds (default off: not
yet measured on a GPU). On Warp's CPU device nothing is captured: ``run_loop`` steps eagerly
through ``wp.capture_while`` (the host reads the counter each turn), which is how it is tested.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import warp as wp

LOOP_ENV = "HARNESS_GRAPH_LOOP"


def graph_loop() -> bool:
    """Whether runs of physics steps are captured as device loops (``HARNESS_GRAPH_LOOP``: 1 or
    0; default 0)."""
    return os.environ.get(LOOP_ENV, "0") not in ("", "0")


@wp.kernel
def set_count(left: wp.array(dtype=wp.int32), count: wp.int32):  # type: ignore[valid-type]
    left[0] = count


@wp.kernel
def count_down(left: wp.array(dtype=wp.int32)):  # type: ignore[valid-type]
    left[0] = left[0] - 1


@dataclass
class LoopGraph:
    """A captured graph that runs ``step`` ``times`` times on the device, and its counter (kept
    alive with it: the graph reads and writes it)."""

    graph: Any
    left: wp.array
    times: int


def run_loop(device: str, step: Callable[[], None], times: int, left: wp.array) -> None:
    """Issue ``times`` calls of ``step`` as a WHILE loop on ``left`` (captured: a conditional
    node; eager: the host reads ``left`` before every turn)."""
    wp.launch(set_count, dim=1, inputs=[left, times], device=device)

    def body() -> None:
        step()
        wp.launch(count_down, dim=1, inputs=[left], device=device)

    wp.capture_while(left, body)


def capture_loop(device: str, step: Callable[[], None], times: int) -> LoopGraph:
    """``run_loop`` captured on ``device`` (CUDA): one launch of the result runs ``times`` steps.
    ``step``'s kernels must already be loaded (one eager call before), and it may not allocate
    (a conditional body holds kernels, memsets, copies and conditionals only)."""
    left = wp.zeros(1, dtype=wp.int32, device=device)
    with wp.ScopedCapture(device=device) as capture:
        run_loop(device, step, times, left)
    assert capture.graph is not None
    return LoopGraph(capture.graph, left, times)
