"""How many lane streams a device runs at once and how many lanes each gets.

A stream's lanes all step whether busy or not, and its first outcome comes one episode span
(~3,600 physics steps, ~9-12 s on an H100 whatever the lanes) after its start: a stream gets
lanes for its own task model's jobs (``default_lanes``), and a device runs several streams side
by side (``streams_per_device``) within a budget of lanes (``CUDA_DEVICE_LANES``).
"""

from __future__ import annotations

import math
import os

from harness.errors import HarnessError

# Lanes per stream: CUDA devices step 8,192 worlds at 2.6-3.2 M world-steps/s on an H100
# (docs/engines.md, "Lanes"); Warp's CPU device is a test device (~60 world-steps/s on this
# project's 2-core machine), a few lanes. ``HARNESS_LANES`` overrides both.
CUDA_LANES = 8192
CPU_LANES = 4
# Lane streams in flight at once on one CUDA device (``HARNESS_STREAMS_PER_DEVICE`` overrides).
# Chosen, no public source: every task model of a sweep or a tune round (the demo and the
# canonical tune have ten) streams at once. At 8, two of the ten waited for a whole stream to
# end (the tune's phases on one H100, 2026-11-28 morning: eight streams, then two). The lanes of
# all streams stay within the device's budget (``even_share``). Warp's CPU device has no streams
# (its slots take turns): one.
CUDA_STREAMS = 16
CPU_STREAMS = 1
# The lanes of all of a CUDA device's streams together (``HARNESS_DEVICE_LANES`` overrides).
# Chosen, no public source: the physics tops out near 16,384-32,768 worlds on an H100
# (3.04-3.21 M world-steps/s, docs/engines.md "Lanes"); more lanes only queue behind them.
CUDA_DEVICE_LANES = 2 * CUDA_LANES

# The fewest lanes a CUDA stream gets (a step of fewer worlds is no faster; with several streams
# on a device, a stream's lanes add to the others' and the device's budget). Chosen, no public
# source.
MIN_CUDA_LANES = 64
# Episodes per lane a stream needs before more lanes pay: every lane steps whether busy or not,
# and a stream's first outcome comes one episode span (~9-12 s on an H100) after its start. On
# one H100, issue 34's 3,000-episode FR3 sweep (one stream) took 46.8 s with 1,024 lanes, 50.7 s
# with 2,048 and 76.6 s with 8,192 (docs/engines.md); chosen from those three runs. With a share
# group's episodes on the device together (2026-11-27 night, one H200): 53.0 s with 1,024 lanes,
# 54.4 s with 4,096 (a step of 1,024 worlds is latency-bound; more lanes cost as much as they
# save).
EPISODES_PER_LANE = 3
# A stream of at most this many jobs gets a lane per job (a power of two), so its jobs take one
# episode span, not ``EPISODES_PER_LANE``: below it a step is latency-bound (a 64-lane demo
# stream alone steps at 1.6-2.6 ms, a 1,024-lane FR3 stream at 3.1 ms; docs/engines.md, "The
# sittings of 2026-11-27, late night"), so the idle lanes of a short stream cost little and
# its outcomes come two spans sooner. Chosen, no public source; issue 34's tune rounds of 112
# jobs took two spans of a 64-lane stream.
SPAN_LANES = 512


def is_cuda(device: str) -> bool:
    """A CUDA device's name (``cuda:0``), by its name alone (no Warp import: the stubs)."""
    return device.startswith("cuda")


def env_int(name: str) -> int | None:
    """The positive integer an environment variable sets, else None; one line naming the
    variable where it is not an integer."""
    chosen = os.environ.get(name)
    if not chosen:
        return None
    try:
        return max(1, int(chosen))
    except ValueError:
        raise HarnessError(f"environment variable {name}={chosen!r}: not an integer") from None


def env_flag(name: str) -> bool:
    """Whether an on/off environment variable is on: set to anything but empty or ``0``."""
    return os.environ.get(name, "0") not in ("", "0")


def streams_per_device(device: str) -> int:
    """``HARNESS_STREAMS_PER_DEVICE``, else ``CUDA_STREAMS`` on a CUDA device, else
    ``CPU_STREAMS``."""
    chosen = env_int("HARNESS_STREAMS_PER_DEVICE")
    if chosen:
        return chosen
    return CUDA_STREAMS if is_cuda(device) else CPU_STREAMS


def default_lanes(device: str, episodes: int | None = None) -> int:
    """``HARNESS_LANES``, else on the CPU ``CPU_LANES``, else on a CUDA device the power of
    two nearest above ``episodes`` (up to ``SPAN_LANES`` episodes: one span), else above
    ``episodes / EPISODES_PER_LANE``, between ``MIN_CUDA_LANES`` (``SPAN_LANES`` past it) and
    ``CUDA_LANES`` (``CUDA_LANES`` when the stream's size is not known)."""
    chosen = env_int("HARNESS_LANES")
    if chosen:
        return chosen
    if not is_cuda(device):
        return CPU_LANES
    if episodes is None:
        return CUDA_LANES
    if episodes <= SPAN_LANES:
        return max(MIN_CUDA_LANES, 1 << (max(1, episodes) - 1).bit_length())
    wanted = math.ceil(episodes / EPISODES_PER_LANE)
    return max(SPAN_LANES, min(CUDA_LANES, 1 << (wanted - 1).bit_length()))


def even_share(budget: int, wants: list[int], floor: int) -> int:
    """The most lanes one stream takes while task models wanting ``wants`` lanes stream at once:
    the device's ``budget`` filled evenly (a model wanting less than an even share leaves the
    rest to the others), in whole multiples of ``floor`` and at least ``floor``; ``budget`` when
    all fit. So every model streams at once, rather than the first few taking the budget and the
    rest waiting a whole stream (a tune's refinement on one H100: ten models of 4,000 jobs
    wanted 2,048 lanes each, eight filled the 16,384 and two waited)."""
    left, ordered = budget, sorted(wants)
    for i, want in enumerate(ordered):
        share = left // (len(ordered) - i)
        if want > share:
            return max(floor, share // floor * floor)
        left -= want
    return budget
