"""Typed access to DataFrame columns and rows for the report.

pandas annotates ``frame[name]`` as Series-or-DataFrame and a row's cells as a union of every
scalar and container type, although a column name selects one Series and a cell's type follows
its column. These helpers say what the report's code relies on, explicitly and in one place, so
the report code itself type-checks without ignores.
"""

from __future__ import annotations

from collections.abc import Hashable, Iterator
from typing import Any, cast

import pandas as pd


def column(frame: pd.DataFrame, name: Hashable) -> pd.Series:
    """The column ``name`` of ``frame`` (a single label always selects one Series)."""
    return cast(pd.Series, frame[name])


def frame_of(value: Any) -> pd.DataFrame:
    """``value`` known to be a DataFrame (selection by a list of columns, a boolean mask, ...)."""
    return cast(pd.DataFrame, value)


def series_rows(frame: pd.DataFrame) -> Iterator[Any]:
    """The rows of ``frame`` as ``iterrows`` gives them (one Series per row).

    Typed ``Any``: a cell's type depends on its column, which pandas' annotations cannot say.
    """
    for _, row in frame.iterrows():
        yield row


def tuple_rows(frame: pd.DataFrame) -> Iterator[Any]:
    """The rows of ``frame`` as ``itertuples`` gives them (named tuples of the columns).

    Typed ``Any``: the fields are the frame's columns, unknown to the type checker.
    """
    yield from frame.itertuples()


def series_of(value: Any) -> pd.Series:
    """``value`` known to be a Series (a grouped column's aggregate, a selected row, ...)."""
    return cast(pd.Series, value)
