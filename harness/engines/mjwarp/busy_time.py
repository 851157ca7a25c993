"""How long a device was busy when several batches may be on it at once: the length of the union
of their (start, end) spans, not their sum."""

from __future__ import annotations


def union_length(spans: list[tuple[float, float]]) -> float:
    """The length of the union of the intervals ``(start, end)``."""
    total, end = 0.0, float("-inf")
    for start, stop in sorted(spans):
        if stop > end:
            total += stop - max(start, end)
            end = stop
    return total
