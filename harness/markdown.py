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


def markdown_cell(value: Any, escape_html: bool = True) -> str:
    """A value as one table cell: HTML escaped (``markdown_text``) unless ``escape_html`` is
    off (text for a terminal, where ``&gt;`` would be printed as is), ``|`` escaped."""
    text = markdown_text(value) if escape_html else str(value).replace("\n", " ")
    return text.replace("|", "\\|")


def markdown_table(
    header: Sequence[Any], rows: Iterable[Sequence[Any]], escape_html: bool = True
) -> list[str]:
    """The lines of a Markdown table: the header, the ``|---|`` rule, one line per row.
    ``escape_html=False``: the same table for a terminal (cells keep ``<`` and ``>``)."""

    def line(cells: Sequence[Any]) -> str:
        return "| " + " | ".join(markdown_cell(c, escape_html) for c in cells) + " |"

    return [line(header), "|" + "---|" * len(header), *(line(row) for row in rows)]
