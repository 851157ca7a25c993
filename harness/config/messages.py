"""Helpers that phrase configuration error messages: key suggestions and short reprs."""

from __future__ import annotations

import difflib
from typing import Any


def suggest(key: str, valid: Any) -> str:
    """``; did you mean 'x'?`` for the closest of ``valid`` to ``key``, or ``""``."""
    close = difflib.get_close_matches(str(key), [str(v) for v in valid], n=1, cutoff=0.5)
    return f"; did you mean {close[0]!r}?" if close else ""


def short_repr(value: Any, limit: int = 60) -> str:
    """``repr`` cut to ``limit`` characters, so one huge value cannot flood the error line."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."
