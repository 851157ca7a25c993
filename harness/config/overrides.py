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


# A --set value or sweep axis value is a key's value: a list of two xyz triples is three
# levels deep. YAML flow syntax (``[[[[...]]]]``) nests as deep as its text is long, and
# pydantic and the episode id walk it recursively (RecursionError at ~1000 levels).
MAX_VALUE_DEPTH = 32


def check_depth(value: Any, key: str) -> None:
    """``ValueError`` if ``value`` nests lists / dicts more than ``MAX_VALUE_DEPTH`` deep
    (checked without recursion, so any depth is refused in linear time)."""
    stack: list[tuple[Any, int]] = [(value, 0)]
    while stack:
        node, depth = stack.pop()
        if depth > MAX_VALUE_DEPTH:
            raise ValueError(f"the value of {key} nests more than {MAX_VALUE_DEPTH} levels deep")
        if isinstance(node, dict):
            stack.extend((item, depth + 1) for item in node.values())
        elif isinstance(node, list | tuple):
            stack.extend((item, depth + 1) for item in node)


def inherit_placement(data: dict[str, Any], key: str) -> None:
    """Before ``robot_placement.<k>`` or ``objects.<i>.placement.<k>`` is set on a task that
    sets no such placement, start from the one the task inherits from robot.yaml (the robot's
    ``placement``, the arm's ``object_region``), so the keys not named keep their values. A
    nested override merges into what the task runs with; it never resets a sibling."""
    from harness.config.robot_registry import placement_defaults

    parts = key.split(".")
    if len(parts) > 1 and parts[0] == "robot_placement":
        section, container = "robot_placement", data
    elif len(parts) > 3 and parts[0] == "objects" and parts[2] == "placement":
        objects = data.get("objects") or []
        index = int(parts[1]) if parts[1].isdigit() else -1
        if not 0 <= index < len(objects) or not isinstance(objects[index], dict):
            return
        section, container = "object", objects[index]
    else:
        return
    field = "robot_placement" if section == "robot_placement" else "placement"
    if container.get(field) is not None:
        return
    inherited = placement_defaults(str(data.get("robot")), str(data.get("arm")))[section]
    if inherited is not None:
        container[field] = dict(inherited)


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
    """Parse the value of ``--set key=value`` as YAML (so lists and numbers work).

    ``ValueError`` for a value nested more than ``MAX_VALUE_DEPTH`` deep: the YAML parser
    recurses per level, so the depth is counted in the text before it parses anything.
    """
    depth = deepest = 0
    for char in text:
        if char in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif char in "]}":
            depth -= 1
    if deepest > MAX_VALUE_DEPTH:
        raise ValueError(f"the value nests more than {MAX_VALUE_DEPTH} levels deep")
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError:
        return text
    except RecursionError:  # block-style nesting the count above does not see
        raise ValueError(f"the value nests more than {MAX_VALUE_DEPTH} levels deep") from None


def apply_overrides(task: TaskConfig, overrides: dict[str, Any]) -> TaskConfig:
    """Return a validated copy of ``task`` with dotted-key overrides applied."""
    data = task.model_dump(mode="json", exclude_none=False)
    for key, value in overrides.items():
        try:
            check_dotted_key(key)
            check_depth(value, key)
            inherit_placement(data, canonical_key(key, target_index(data)))
            set_dotted(data, key, value)
        except KeyError as exc:  # str(KeyError) quotes its message
            raise ConfigError(str(exc.args[0]), file=task.source, key=key) from None
        except (ValueError, IndexError, TypeError) as exc:
            raise ConfigError(str(exc), file=task.source, key=key) from None
    try:
        return TaskConfig.model_validate(data)
    except ValidationError as exc:
        error = error_from_validation(exc, TaskConfig, None).with_file(task.source)
        if error.key and error.key.startswith(("gripper", "timing")):  # file and axis spelling
            error = ConfigError(error.message, file=error.file, key=f"robot.{error.key}")
        raise error from None
