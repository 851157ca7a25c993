"""The rich console the commands print with."""

from __future__ import annotations

from rich.console import Console

# Without a terminal (CI logs, nox, pipes) rich assumes 80 columns and squeezes the summary
# tables into unreadable wrapped cells; logs have room for more.
NON_TERMINAL_WIDTH = 140


def make_console() -> Console:
    console = Console()
    if not console.is_terminal:
        console = Console(width=NON_TERMINAL_WIDTH)
    return console
