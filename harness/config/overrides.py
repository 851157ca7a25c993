"""Dotted-key overrides (``--set pick.filter_z_dir=...``, sweep points) applied to a task."""

from __future__ import annotations

from typing import Any

import yaml
from pydantic import ValidationError

from harness.config.errors import ConfigError
from harness.config.sweep import canonical_key, check_dotted_key
from harness.config.task import TaskConfig
from harness.config.validation import error_from_validation


def set_dotted(data: dict[str, Any], key: str, value: Any) -> None:
    """Set ``pick.filter_z_dir`` / ``objects.0.mass`` / ``object.friction`` /
    ``robot.gripper.force_limit`` in a nested dict (a task's ``model_dump``). ``object.`` is
    the picked object (``pick.objects[0]``), wherever it is in ``objects``."""
    parts = canonical_key(key, target_index(data)).split(".")
    node: Any = data
    for index, part in enumerate(parts[:-1]):
        nxt = parts[index + 1]
        if isinstance(node, list):
            node = node[int(part)]
            continue
        if part not in node or node[part] is None:
            node[part] = [] if nxt.isdigit() else {}
        node = node[part]
    last = parts[-1]
    if isinstance(node, list):
        node[int(last)] = value
    else:
        node[last] = value


def target_index(data: dict[str, Any]) -> int:
    """Index in ``data["objects"]`` of the picked object (``pick.objects[0]``; the first object
    when the pick names none), in a task's ``model_dump``."""
    objects = data.get("objects") or []
    wanted = (data.get("pick") or {}).get("objects") or []
    names = [obj.get("name") for obj in objects if isinstance(obj, dict)]
    if wanted and wanted[0] in names:
        return names.index(wanted[0])
    return 0


def parse_set_value(text: str) -> Any:
    """Parse the value of ``--set key=value`` as YAML (so lists and numbers work)."""
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError:
        return text


def apply_overrides(task: TaskConfig, overrides: dict[str, Any]) -> TaskConfig:
    """Return a validated copy of ``task`` with dotted-key overrides applied."""
    data = task.model_dump(mode="json", exclude_none=False)
    for key, value in overrides.items():
        try:
            check_dotted_key(key)
            set_dotted(data, key, value)
        except KeyError as exc:  # str(KeyError) quotes its message
            raise ConfigError(str(exc.args[0]), file=task.source, key=key) from None
        except (ValueError, IndexError, TypeError) as exc:
            raise ConfigError(str(exc), file=task.source, key=key) from None
    try:
        return TaskConfig.model_validate(data)
    except ValidationError as exc:
        error = error_from_validation(exc, TaskConfig, None).with_file(task.source)
        if error.key and error.key.startswith("gripper"):  # the file and axis spelling
            error = ConfigError(error.message, file=error.file, key=f"robot.{error.key}")
        raise error from None
