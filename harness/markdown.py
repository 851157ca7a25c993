"""Markdown tables: the one writer behind the run report, the benchmark table and the sweep
summary shown in Rerun, so every table escapes its cells the same way."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any


def markdown_text(value: Any) -> str:
    """Text from the data (task, object, robot names, messages) made inert in Markdown: raw
    HTML is escaped (Markdown passes ``<script>`` through to the page), line breaks become
    spaces."""
    return (
        str(value)
        .replace("&", "&amp;")
        .replace("<", "&lt;")
        .replace(">", "&gt;")
        .replace("\n", " ")
    )


def markdown_cell(value: Any) -> str:
    """A value as one table cell: HTML escaped (``markdown_text``), ``|`` escaped."""
    return markdown_text(value).replace("|", "\\|")


def markdown_table(header: Sequence[Any], rows: Iterable[Sequence[Any]]) -> list[str]:
    """The lines of a Markdown table: the header, the ``|---|`` rule, one line per row."""
    lines = ["| " + " | ".join(markdown_cell(h) for h in header) + " |"]
    lines.append("|" + "---|" * len(header))
    lines += ["| " + " | ".join(markdown_cell(c) for c in row) + " |" for row in rows]
    return lines
