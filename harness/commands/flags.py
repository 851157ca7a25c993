"""argparse types of the command line: each bad value is one usage line naming the flag
(argparse prints ``argument --flag: <reason>``), never a traceback or a value that fails later."""

from __future__ import annotations

import argparse
import math
import re
from collections.abc import Callable


def bounded_int(low: int, high: int) -> Callable[[str], int]:
    """An argparse type: an integer in [low, high], else one clear usage error."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"{value} is outside [{low:,}, {high:,}]")
        return value

    return parse


def seconds_at_least(low: float) -> Callable[[str], float]:
    """An argparse type: a finite number of seconds >= low, else one clear usage error."""

    def parse(text: str) -> float:
        value = finite(text)
        if value < low:
            raise argparse.ArgumentTypeError(f"{value:g} s is below the shortest, {low:g} s")
        return value

    return parse


def finite(text: str) -> float:
    """An argparse type: a finite number, else one clear usage error."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite number")
    return value


def positive(text: str) -> float:
    """An argparse type: a finite number > 0, else one clear usage error."""
    value = finite(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"{value:g} is not positive")
    return value


def record_policy(text: str) -> str:
    """An argparse type: none | failures | invalid | all | sample:N (``RECORD_HELP``)."""
    if text in ("none", "failures", "invalid", "all") or re.fullmatch(r"sample:[1-9]\d*", text):
        return text
    raise argparse.ArgumentTypeError(
        f"{text!r}: expected none, failures, invalid, all or sample:N with N >= 1"
    )


RECORD_HELP = "none|failures|invalid|all|sample:N"
SEED = bounded_int(0, 2**63 - 1)
# The config's own cap (SweepConfig.episodes_per_point <= 100,000): a larger flag would pass
# argparse and fail later in pydantic with a traceback.
EPISODES = bounded_int(1, 100_000)
GRASP_COUNT = bounded_int(1, 1_000_000)
WORKERS = bounded_int(1, 1024)
