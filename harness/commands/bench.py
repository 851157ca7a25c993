"""``harness bench``: run the benchmark sections and print / save the results."""

from __future__ import annotations

import argparse

from harness.bench import SECTIONS, main_bench
from harness.errors import HarnessError


def main(args: argparse.Namespace) -> int:
    unknown = [name for name in args.only or [] if name not in SECTIONS]
    if unknown:
        raise HarnessError(f"unknown bench section(s) {unknown}; available: {list(SECTIONS)}")
    main_bench(args.only, args.quick, args.json)
    return 0
