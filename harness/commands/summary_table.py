"""The per-point summary as the terminal shows it: the objective's rate first, then why the rest
miss it, then the other rate, in 80 columns without cutting a setting or an interval.

One table serves ``harness sweep``, ``harness run``'s report and ``harness report``. Its columns,
left to right: the unit (robot, arm and object, once per group of rows), one column per swept
setting (the key's last part; values never cut), the objective's ``k/n rate`` and its 95% Wilson
interval (never cut), the top reasons the other episodes miss the objective (for ``valid``: the
failure reasons and the reasons a reference success was not valid, ``harness.report.answer
.causes``; this column wraps), and the other verdict's rate, named (``reference success``).
"""

from __future__ import annotations

import math
from collections import Counter
from typing import Any

import pandas as pd
from rich import box
from rich.table import Table
from rich.text import Text

from harness.report.answer import causes
from harness.report.frames import series_rows
from harness.report.labels import format_value
from harness.report.objective import RATES, REFERENCE, VALID, other
from harness.report.tables import setting_params

# What the other verdict is called in the table's last column.
RATE_NAMES = {VALID: "valid", REFERENCE: "reference success"}
CAUSES_SHOWN = 2  # reasons named per row; the rest are counted as "+k more"


def header_lines(name: str, width: int) -> str:
    """A key too wide for its values, broken after an underscore: ``approach_\\nfilter``."""
    if len(name) <= width or "_" not in name:
        return name
    lines, line = [], ""
    for part in name.split("_"):
        piece = f"{line}_{part}" if line else part
        if line and len(piece) > width:
            lines.append(line + "_")
            line = part
        else:
            line = piece
    return "\n".join([*lines, line])


def rate_cells(row: Any, objective: str) -> tuple[str, str]:
    """``17/40 42%`` and ``0.28–0.58`` for the objective's rate; blank when nothing was rated."""
    k, n, rate, lo, hi = RATES[objective].of(row)
    if not n:
        return ("not judged" if objective == VALID else "none rated"), ""
    interval = "" if math.isnan(lo) else f"{lo:.2f}–{hi:.2f}"
    return f"{k}/{n} {rate:.0%}", interval


def miss_cell(row: Any, objective: str) -> str:
    """Why the episodes that miss the objective miss it, a reason and its count a line, the
    most frequent first: ``table_penetration 22`` / ``no_contact 1``."""
    counts: Counter[str] = causes(row, objective)
    ranked = sorted(counts.items(), key=lambda item: (-item[1], item[0]))
    lines = [f"{reason} {count}" for reason, count in ranked[:CAUSES_SHOWN]]
    if len(ranked) > CAUSES_SHOWN:
        rest = sum(count for _, count in ranked[CAUSES_SHOWN:])
        lines[-1] += f", {rest} other"
    return "\n".join(lines)


def other_cell(row: Any, objective: str) -> str:
    """The other verdict's ``k/n rate`` (``-`` when it rated nothing)."""
    k, n, rate, *_ = RATES[other(objective)].of(row)
    return f"{k}/{n} {rate:.0%}" if n else "-"


def lead_name(objective: str) -> str:
    """The objective's column: ``valid``, or ``success`` (the reference's own check)."""
    return VALID if objective == VALID else "success"


def summary_table(summary: pd.DataFrame, objective: str) -> Table:
    """The table (module docstring), titled ``valid per point``; ``objective`` is the effective
    one (``valid`` or ``reference``). The run's paths follow it (a long path in the title would
    wrap at the table's width)."""
    params = setting_params(summary)
    lead = lead_name(objective)
    table = Table(
        title=f"{lead} per point",
        box=box.SIMPLE_HEAD,
        show_edge=False,
        pad_edge=False,
        padding=(0, 1, 0, 0),
        title_justify="left",
        caption=(
            f"{lead}: the objective, ranked by; not {lead}: why the rest miss it; "
            f"{RATE_NAMES[other(objective)]}: the other verdict"
        ),
        caption_justify="left",
    )
    rows = list(series_rows(summary))
    if not params:
        table.add_column("robot arm object", min_width=11)
    for index, name in enumerate(params):
        values = [format_value(row[name]) for row in rows]
        width = max((len(v) for v in values), default=1)
        key = name.split(".")[-1]
        if index == 0:  # it also holds the unit rows, which wrap to the values' width
            width = max(width, 11)
            table.add_column(header_lines(key, width), min_width=width, max_width=width)
        else:
            table.add_column(header_lines(key, max(width, 6)), no_wrap=True, min_width=width)
    judged = [rate_cells(row, objective) for row in rows]
    rate_width = max((len(cell[0]) for cell in judged), default=5)
    ci_width = max((len(cell[1]) for cell in judged), default=6)
    table.add_column(lead, justify="right", no_wrap=True, min_width=rate_width)
    table.add_column("95% CI", justify="right", no_wrap=True, min_width=ci_width)
    table.add_column(f"not {lead}", overflow="fold", min_width=12)
    table.add_column(RATE_NAMES[other(objective)].replace(" ", "\n"), justify="right", no_wrap=True)
    blank = [""] * (len(params) + 3)
    previous: tuple[str, str, str] | None = None
    for row, (rate, interval) in zip(rows, judged, strict=True):
        unit = (str(row["robot"]), str(row["arm"]), str(row["object"]))
        cells = [rate, interval, miss_cell(row, objective), other_cell(row, objective)]
        if not params:  # one row per unit: the unit is the first cell
            table.add_row(" ".join(unit), *cells)
            continue
        if unit != previous:  # the unit on a row of its own, above its settings
            if previous is not None:
                table.add_section()
            table.add_row(Text(" ".join(unit), style="bold"), *blank)
        table.add_row(*[format_value(row[name]) for name in params], *cells)
        previous = unit
    return table
