"""Swept parameter values and sweep points as people read them (tables, plots, the CLI).

``format_value`` turns a ``param.*`` cell into text (JSON lists as ``downward 140``, floats
compactly); ``point_label`` joins a point's values; ``varying_params`` picks the swept columns
worth showing.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np
import pandas as pd

from harness.report.frames import column
from harness.row import param_columns


def format_value(value: Any) -> str:
    """A parameter value for people: JSON lists as ``downward 140``, floats compactly."""
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value))
    if isinstance(value, (float, np.floating)):
        return "" if math.isnan(value) else f"{float(value):g}"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    text = str(value)
    if text.startswith("["):
        try:
            parsed = json.loads(text)
        except json.JSONDecodeError:
            return text
        if isinstance(parsed, list):
            return " ".join(format_value(v) for v in parsed)
    return text


def point_label(row: pd.Series | dict[str, Any], params: list[str]) -> str:
    """``filter_z_dir=downward 140, pre_grasp_offset=0.1`` (the last key part only)."""
    if not params:
        return "default"
    parts = [f"{name.split('.')[-1]}={format_value(row[name])}" for name in params]
    return ", ".join(parts)


def varying_params(frame: pd.DataFrame) -> list[str]:
    """Swept parameter columns that take more than one value in ``frame``."""
    return [
        name
        for name in param_columns(frame.columns)
        if column(frame, name).nunique(dropna=True) > 1
    ]
