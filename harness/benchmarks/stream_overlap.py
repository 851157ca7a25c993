"""Benchmark: do lane streams on one GPU step at the same time?

``harness sweep --engine mjwarp`` runs up to ``HARNESS_STREAMS_PER_DEVICE`` lane streams per
device, each a captured CUDA graph of physics steps on a CUDA stream of its own. A demo sweep on
an H200 took 63-80 s for a stream's first outcome with eight 64-lane streams at once, about
eight times the span one stream alone takes: as if the device ran one stream's step at a time.
This measures it without the engine: ``streams`` copies of one task model's settled state (the
FR3 cube, ``harness.benchmarks.noslip_kernels.settled_state``), ``worlds`` worlds each, each
with a graph of ``steps`` physics steps captured on its own stream; a round launches every
stream's graph and waits for all. Figures per (worlds, streams, noslip): ms per physics step
of a round, world-steps/s, and the overlap ``streams x t(1 stream) / t(streams)`` (1: the
streams run one after another; ``streams``: fully side by side).

    python -m harness.benchmarks.stream_overlap OUT_DIR --worlds 64 512 --streams 1 2 4 8

``--graphs unrolled loop`` measures both graph kinds in one run (the product's visit is ~136
steps: ``--steps 136``), to see whether the launches of long unrolled graphs, not the device,
hold the streams back.
"""

from __future__ import annotations

import argparse
import json
import time
from functools import partial
from itertools import product
from pathlib import Path
from typing import Any


def round_ms(
    task_file: str,
    worlds: int,
    streams: int,
    steps: int,
    rounds: int,
    noslip: bool,
    loop: bool = False,
) -> float:
    """ms per physics step of a round of ``streams`` graphs of ``steps`` steps: unrolled, or
    with ``loop`` one step in a device-side WHILE loop (``harness.engines.mjwarp.graph_loop``)."""
    import mujoco_warp as mjw
    import warp as wp

    from harness.benchmarks.noslip_kernels import settled_state
    from harness.engines.mjwarp import noslip as noslip_pass
    from harness.engines.mjwarp.graph_loop import loop_steps

    noslip_pass.install()
    m, d = settled_state(task_file)
    mw = mjw.put_model(m)
    if not noslip:
        mw.opt.noslip_iterations = 0
    kept: list[Any] = []
    for _ in range(streams):
        stream = wp.Stream()
        with wp.ScopedStream(stream):
            dw = mjw.put_data(m, d, nworld=worlds, nconmax=64, njmax=256)
            mjw.step(mw, dw)  # loads the kernels, makes the noslip buffers
            if loop:
                looped = loop_steps(str(stream.device), partial(mjw.step, mw, dw), steps)
                assert looped is not None
                kept.append((stream, (dw, looped), looped.graph))
                continue
            with wp.ScopedCapture(stream=stream) as capture:
                for _ in range(steps):
                    mjw.step(mw, dw)
        kept.append((stream, dw, capture.graph))
    wp.synchronize()
    for stream, _, graph in kept:  # one warm round
        wp.capture_launch(graph, stream=stream)
    wp.synchronize()
    clock = time.perf_counter()
    for _ in range(rounds):
        for stream, _, graph in kept:
            wp.capture_launch(graph, stream=stream)
        wp.synchronize()
    return 1000.0 * (time.perf_counter() - clock) / (rounds * steps)


def main() -> None:
    from harness.writes import write_file

    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--task", default="tasks/pick/fr3.yaml")
    parser.add_argument("--worlds", type=int, nargs="+", default=[64, 512])
    parser.add_argument("--streams", type=int, nargs="+", default=[1, 2, 4, 8])
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--rounds", type=int, default=10)
    parser.add_argument(
        "--graphs", nargs="+", choices=["unrolled", "loop"], default=["unrolled"],
        help="a graph's steps unrolled, or one step in a device-side loop (both: one run)",
    )  # fmt: skip
    parser.add_argument("--noslip", choices=["both", "on", "off"], default="both")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    records = []
    noslips = {"both": (True, False), "on": (True,), "off": (False,)}[args.noslip]
    for noslip, graphs, worlds in product(noslips, args.graphs, args.worlds):
        alone = None
        for streams in args.streams:
            ms = round_ms(
                args.task, worlds, streams, args.steps, args.rounds, noslip, graphs == "loop"
            )
            alone = ms if streams == 1 else alone
            record = {
                "noslip": noslip, "graphs": graphs, "worlds": worlds, "streams": streams,
                "ms_per_step": ms, "world_steps_per_s": streams * worlds / (ms / 1000.0),
                "overlap": streams * alone / ms if alone else None,
            }  # fmt: skip
            records.append(record)
            print(json.dumps(record), flush=True)
            write_file(args.out / "stream_overlap.json", json.dumps(records, indent=1))


if __name__ == "__main__":
    main()
