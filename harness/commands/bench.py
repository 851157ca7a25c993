"""``harness bench``: run the benchmark sections and print / save the results."""

from __future__ import annotations

import argparse

from harness.benchmarks.framework import SECTIONS, main_bench
from harness.errors import HarnessError


def main(args: argparse.Namespace) -> int:
    """Exit 0 when every section ran (targets missed or not: they are findings, not errors),
    1 when a section raised."""
    known = SECTIONS
    unknown = [name for name in args.only or [] if name not in known]
    if unknown:
        raise HarnessError(f"unknown bench section(s) {unknown}; available: {list(known)}")
    runs = main_bench(args.only, args.quick, args.json)
    return 1 if any(run.error for run in runs) else 0
