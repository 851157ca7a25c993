"""``tuned.yaml`` and ``tuned.md``: the tuned pick block per robot and arm, with its evidence.

The block is the task's own pick block (its reference keys that differ from the defaults) with
the tuned filters in that robot's keys: the approach filter on ``filter_<approach axis>_dir``,
the facing filter on ``filter_<facing axis>_dir`` (robots/<name>/robot.yaml ``convention``:
fr3 and split_aloha approach along EE z, lift2 along EE x). Harness-only keys (``semantics``,
``approach_filter``, ``timing``, ...) are left out, so the block pastes into an InternDataEngine
task file as it is; the evidence (rate, interval, n, McNemar p) is in comments.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pandas as pd
import yaml

from harness.config import TaskConfig
from harness.config.pick import PickConfig, harness_only_keys
from harness.grasps import resolve_filters
from harness.grasps.filters import FILTER_KEYS
from harness.markdown import markdown_table
from harness.report.frames import frame_of, series_rows
from harness.robots.facts import reference_convention
from harness.tuning.analysis import POOLED, filter_label

# PickConfig keys that only the harness reads (not InternDataEngine's Pick skill): marked on
# the model (``harness.config.pick.HARNESS_ONLY``).
HARNESS_PICK_KEYS = harness_only_keys()
# ``objects`` names the task's own objects: the file it is pasted into keeps its own.
SKIPPED_KEYS = HARNESS_PICK_KEYS | {"objects"}
AXIS_KEYS = tuple(FILTER_KEYS.values())
PICK_ORDER = tuple(PickConfig.model_fields)  # a block lists its keys in PickConfig order


def _number(value: Any) -> Any:
    return int(value) if isinstance(value, float) and value.is_integer() else value


def pick_block(task: TaskConfig, approach: str, facing: str) -> dict[str, Any]:
    """The task's reference pick keys with the tuned filters in the robot's own keys.

    Keys at their default are left out (a run directory's task no longer says which keys its
    file set), as are harness-only keys and ``objects``.
    """
    convention = reference_convention(task.robot)
    filters = {key: spec.as_list() for key, spec in resolve_filters(task.pick, convention).items()}
    for axis, text in ((convention.approach_axis, approach), (convention.facing_axis, facing)):
        value = json.loads(text) if text else None
        if value:
            filters[FILTER_KEYS[axis]] = value
        else:
            filters.pop(FILTER_KEYS[axis], None)
    dumped = task.pick.model_dump(mode="json")
    defaults = PickConfig().model_dump(mode="json")
    block: dict[str, Any] = {}
    for key in PICK_ORDER:
        if key in AXIS_KEYS:
            if key in filters:
                block[key] = [_number(v) for v in filters[key]]
        elif key not in SKIPPED_KEYS and dumped[key] != defaults[key]:
            block[key] = _number(dumped[key])
    return block


def _evidence(row: Any, prefix: str = "") -> str:
    return (
        f"{int(row[prefix + 'successes'])}/{int(row[prefix + 'n'])} = {row[prefix + 'rate']:.0%} "
        f"(95% CI {row[prefix + 'lo']:.2f}-{row[prefix + 'hi']:.2f}, n = {int(row[prefix + 'n'])})"
    )


def _setting(approach: str, facing: str) -> str:
    return f"approach {filter_label(approach)} / facing {filter_label(facing)}"


def comment_lines(row: Any, objective: str) -> list[str]:
    """The evidence of one robot/arm choice as comment lines (without the ``#``)."""
    return [
        f"tuned:   {_setting(row['approach'], row['facing'])}: {_evidence(row)}",
        f"current: {_setting(row['current_approach'], row['current_facing'])}: "
        f"{_evidence(row, 'current_')}",
        f"exact McNemar, tuned vs current on {int(row['pairs'])} shared seeds: "
        f"{int(row['only_best'])} tuned-only and {int(row['only_current'])} current-only "
        f"successes, p = {row['p_value']:.3g}",
        f"objective {objective}; best of {int(row['points'])} settings by the interval's "
        "lower bound",
    ]


def tuned_yaml(chosen: pd.DataFrame, tasks: dict[tuple[str, str], TaskConfig], header: list[str],
               objective: str) -> str:  # fmt: skip
    """The text of ``tuned.yaml``: ``robot: arm: pick: {...}`` with comment evidence."""
    lines = [f"# {line}" for line in header]
    pooled = frame_of(chosen[chosen["object"] == POOLED])
    robot = None
    for row in series_rows(pooled):
        if row["robot"] != robot:
            robot = row["robot"]
            lines.append(f"{robot}:")
        lines.append(f"  {row['arm']}:")
        lines.extend(f"    # {line}" for line in comment_lines(row, objective))
        block = pick_block(
            tasks[(str(row["robot"]), str(row["arm"]))], row["approach"], row["facing"]
        )
        text = yaml.safe_dump({"pick": block}, sort_keys=False, default_flow_style=None)
        lines.extend(f"    {line}" for line in text.splitlines())
    return "\n".join(lines) + "\n"


def tuned_markdown(chosen: pd.DataFrame, yaml_text: str, header: list[str],
                   heatmaps: dict[tuple[str, str, str], Path]) -> str:  # fmt: skip
    """``tuned.md``: the choice table (per object and pooled) and the blocks."""
    rows = []
    for row in series_rows(chosen):
        key = (str(row["robot"]), str(row["arm"]), str(row["object"]))
        image = heatmaps.get(key)
        rows.append(
            [
                *key,
                _setting(row["approach"], row["facing"]),
                _evidence(row),
                _setting(row["current_approach"], row["current_facing"]),
                _evidence(row, "current_"),
                f"{int(row['only_best'])} / {int(row['only_current'])}",
                f"{row['p_value']:.3g}",
                f"[png]({image.parent.name}/{image.name})" if image else "",
            ]
        )
    columns = ["robot", "arm", "object", "tuned", "tuned rate", "current", "current rate",
               "discordant (tuned / current only)", "McNemar p", "heatmap"]  # fmt: skip
    parts = [
        "# Tuned filter settings",
        "",
        *header,
        "",
        f"Object `{POOLED}`: the robot and arm pooled over its objects (the block in tuned.yaml).",
        "",
        *markdown_table(columns, rows),
        "",
        "## tuned.yaml",
        "",
        "```yaml",
        yaml_text.rstrip(),
        "```",
        "",
    ]
    return "\n".join(parts)
