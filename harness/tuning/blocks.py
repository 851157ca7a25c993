"""``tuned.yaml`` and ``tuned.md``: per task file, the filter keys to merge, with the decision.

Only the filter keys are given, in the keys the task file already uses: ``approach_filter`` /
``facing_filter`` when it sets the robot-neutral form, else the robot's own axis keys (the
approach filter on ``filter_<approach axis>_dir``, the facing filter on
``filter_<facing axis>_dir``; robots/<name>/robot.yaml ``convention``: fr3 and split_aloha
approach along EE z, lift2 along EE x). Every other key of the file (``semantics``, ``timing``,
``validity``, the offsets, ...) stays as it is: the block is merged, not pasted over the pick
block (``--write DIR`` does the merge, :mod:`harness.tuning.write`). A key whose tuned value is
"no filter" is listed as ``null``: remove it.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pandas as pd
import yaml

from harness.config import TaskConfig
from harness.config.pick import harness_only_keys
from harness.grasps.filters import FILTER_KEYS
from harness.markdown import markdown_table
from harness.report.frames import frame_of, series_rows
from harness.robots.facts import reference_convention
from harness.tuning.decisions import file_decision, lines, setting_label

# PickConfig keys that only the harness reads (not InternDataEngine's Pick skill), marked on the
# model: the keys to merge never include them, so they merge into an InternDataEngine file too.
OWN_PICK_KEYS = harness_only_keys()
MERGE_NOTE = (
    "Merge these keys into each task file's pick block (an InternDataEngine file: the skill "
    "block at the key path given; only the filter keys change, keep every other key): "
    "harness tune ... --write DIR writes the merged copies and their diffs."
)


def _number(value: Any) -> Any:
    return int(value) if isinstance(value, float) and value.is_integer() else value


def filter_keys(task: TaskConfig, setting: tuple[str, str]) -> dict[str, list[Any] | None]:
    """The pick keys that set ``setting`` in the form the task uses (None: remove the key)."""
    convention = reference_convention(task.robot)
    keys: dict[str, list[Any] | None] = {}
    for neutral, axis, text in (
        ("approach_filter", convention.approach_axis, setting[0]),
        ("facing_filter", convention.facing_axis, setting[1]),
    ):
        value = json.loads(text) if text else None
        key = neutral if getattr(task.pick, neutral) is not None else FILTER_KEYS[axis]
        keys[key] = [_number(v) for v in value] if value else None
    return keys


def task_decisions(decisions: pd.DataFrame) -> list[tuple[str, dict[str, Any], pd.DataFrame]]:
    """Per task (in order of first appearance): its file decision and its unit rows."""
    out = []
    for task in dict.fromkeys(decisions["task"]):
        rows = frame_of(decisions[decisions["task"] == task])
        out.append((str(task), file_decision(rows), rows))
    return out


def tuned_yaml(
    decisions: pd.DataFrame,
    tasks: dict[str, TaskConfig],
    header: list[str],
    sources: dict[str, str],
    groups: dict[str, list[str]] | None = None,
    pick_paths: dict[str, str] | None = None,
    objects: pd.DataFrame | None = None,
) -> str:
    """The text of ``tuned.yaml``: per task, the keys to merge, with the decision in comments;
    per template group, the template block once (the keys at the pick block's key path of every
    file, ready to paste into the generator's template) and the confirmed overrides."""
    text = [f"# {line}" for line in [*header, MERGE_NOTE]]
    groups, pick_paths = groups or {}, pick_paths or {}
    for name, decided, rows in task_decisions(decisions):
        if name in groups:
            text.extend(
                _template_block(name, decided, rows, groups[name], tasks, pick_paths, objects)
            )
            continue
        first = rows.iloc[0]
        text.append(f"{name}:  # {first['robot']} {first['arm']}, file {sources.get(name, '?')}")
        text.extend(f"  # {line}" for line in lines(rows))
        if not decided["agree"]:
            text.append("  # the objects disagree: no pooled setting; the file keeps its own")
        text.append(f"  # decision: {decided['verdict']} -> {setting_label(decided['setting'])}")
        keys = filter_keys(tasks[name], decided["setting"])
        if name in pick_paths:  # an InternDataEngine file: the keys live in its skill block
            text.append(f"  # at {pick_paths[name]} of the file:")
            block: dict[str, Any] = {"keys": keys}
        else:
            block = {"pick": keys}
        dumped = yaml.safe_dump(block, sort_keys=False, default_flow_style=None)
        text.extend(f"  {line}" for line in dumped.splitlines())
    return "\n".join(text) + "\n"


def _seen(row: Any) -> str:
    gain = float(row["detectable_gain"])
    return f"{gain * 100:+.0f} points" if math.isfinite(gain) else "none"


def tuned_markdown(
    decisions: pd.DataFrame,
    yaml_text: str,
    header: list[str],
    heatmaps: dict[tuple[str, str], Path],
) -> str:
    """``tuned.md``: the decision table per unit and the keys to merge."""
    rows = []
    for row in series_rows(decisions):
        image = heatmaps.get((str(row["task"]), str(row["context"])))
        rows.append(
            [
                f"{row['robot']} {row['arm']} {row['object']}",
                row["verdict"],
                row["setting"],
                f"{row['successes']}/{row['n']} ({row['lo']:.2f}-{row['hi']:.2f})",
                f"{row['reference_rate']:.0%}",
                f"{row['current_successes']}/{row['current_n']} "
                f"({row['current_lo']:.2f}-{row['current_hi']:.2f})",
                f"{row['current_reference_rate']:.0%}",
                f"{row['gain']:+.0%} ({row['gain_lo']:+.2f} to {row['gain_hi']:+.2f})",
                f"{row['screen_rate']:.0%}",
                _seen(row),
                "yes" if row["isolated"] else "",
                f"[png]({image.parent.name}/{image.name})" if image else "",
            ]
        )
    columns = [
        "robot arm object",
        "decision",
        "setting (chosen, else current)",
        "rate on fresh seeds (95% CI)",
        "reference rate",
        "current on the same seeds",
        "current reference rate",
        "paired gain (95% CI)",
        "screening rate",
        "gain its seeds see (80% power)",
        "isolated",
        "map",
    ]
    parts = [
        "# Tune decisions",
        "",
        *header,
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


def _template_block(
    name: str,
    decided: dict[str, Any],
    rows: pd.DataFrame,
    members: list[str],
    tasks: dict[str, TaskConfig],
    pick_paths: dict[str, str],
    objects: pd.DataFrame | None,
) -> list[str]:
    """A template group's part of ``tuned.yaml``."""
    first = rows.iloc[0]
    task = tasks[members[0]]
    where = pick_paths.get(members[0], "pick")
    text = [f"{name}:  # {first['robot']} {first['arm']}: template over {len(members)} files"]
    text.extend(f"  # {line}" for line in lines(rows))
    text.append(f"  # decision: {decided['verdict']} -> {setting_label(decided['setting'])}")
    text.append(f"  # the template (at {where} of every file of the group):")
    dumped = yaml.safe_dump(
        {"template": filter_keys(task, decided["setting"])},
        sort_keys=False,
        default_flow_style=None,
    )
    text.extend(f"  {line}" for line in dumped.splitlines())
    mine = (
        frame_of(objects[objects["group"] == name])
        if objects is not None and len(objects)
        else pd.DataFrame()
    )
    overrides = {}
    for row in series_rows(mine) if len(mine) else []:
        if row["exception"] == "override":
            setting = (str(row["own_best_approach"]), str(row["own_best_facing"]))
            overrides[str(row["task"])] = filter_keys(tasks[str(row["task"])], setting)
    if overrides:
        text.append(
            "  # confirmed exceptions (their own setting beat the template on seeds of their own):"
        )
        dumped = yaml.safe_dump({"overrides": overrides}, sort_keys=False, default_flow_style=None)
        text.extend(f"  {line}" for line in dumped.splitlines())
    else:
        text.append(
            "  # no object's own setting is confirmed better than the template: no overrides"
        )
    return text
