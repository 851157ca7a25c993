"""Benchmark sections for ``harness bench``; each module exposes ``run(quick) -> list[Figure]``."""
