"""The rich console the commands print with, and THE rule for text that reaches a terminal.

Names and paths come from input (a task or object name, ``--out``, a run directory), so no text
the console prints is ever parsed as rich markup (``[/x]`` in a path crashed rich with a
MarkupError) or emoji codes, and control characters are shown, never sent: an ANSI or OSC escape
in a task name (``\\x1b]0;title\\x07``) would otherwise restyle or retitle the user's terminal.
``SafeConsole.render_str`` is the one place rich turns a string into text (``print`` arguments,
table cells and titles), so the rule holds for every call site. Styling written by the harness
goes through ``styled`` (a literal markup template; the values are escaped); plain lines printed
without rich go through ``say``; the CLI's one-line errors go through ``visible``.
"""

from __future__ import annotations

import re
import sys
from typing import Any, TextIO

from rich.console import Console
from rich.markup import escape
from rich.text import Text

# Without a terminal (CI logs, nox, pipes) rich assumes 80 columns and squeezes the summary
# tables into unreadable wrapped cells; logs have room for more.
NON_TERMINAL_WIDTH = 140

# C0 controls except tab and newline, DEL, C1 controls (0x9b is a one-byte CSI on some
# terminals), and the Unicode bidirectional overrides that reorder what a line appears to say.
_CONTROL = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f\u200e\u200f\u202a-\u202e\u2066-\u2069]")


def visible(text: str) -> str:
    """``text`` with every control character written out (``\\x1b``, ``\\u202e``)."""
    return _CONTROL.sub(_escape_char, text)


def _escape_char(match: re.Match[str]) -> str:
    code = ord(match.group())
    return f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}"


class SafeConsole(Console):
    """A rich ``Console`` that never parses markup or emoji in a string and shows controls."""

    def render_str(self, text: str, **kwargs: Any) -> Text:
        kwargs["markup"] = False
        kwargs["emoji"] = False
        return super().render_str(visible(text), **kwargs)


def styled(template: str, **values: object) -> Text:
    """Harness-written markup with input values: ``styled("[bold]{name}[/]: ok", name=n)``.

    ``template`` is a literal of the harness; each value is made visible and markup-escaped
    before it is filled in, so a value can never open or close a tag.
    """
    escaped = {key: escape(visible(str(value))) for key, value in values.items()}
    return Text.from_markup(template.format(**escaped), emoji=False)


def say(line: str = "", file: TextIO | None = None) -> None:
    """``print`` for plain lines that may hold names: controls shown, no rich involved."""
    print(visible(line), file=file if file is not None else sys.stdout)


def videos_possible(wanted: bool) -> bool:
    """``--videos`` as it can be honoured: the GL backend is chosen and tried (in a child
    process) before anything imports mujoco; where no offscreen context can be made, one line
    says so and the run goes on without videos (its rows and report are still written)."""
    if not wanted:
        return False
    from harness.viz.render import offscreen_gl_problem

    problem = offscreen_gl_problem()
    if problem is not None:
        say(f"warning: videos skipped: {problem}", file=sys.stderr)
    return problem is None


def make_console() -> Console:
    console = SafeConsole(markup=False, emoji=False)
    if not console.is_terminal:
        console = SafeConsole(markup=False, emoji=False, width=NON_TERMINAL_WIDTH)
    return console
