"""YAML loading that remembers where every key came from.

Config errors must point at ``file:line key.path``; PyYAML's plain ``safe_load`` forgets line
numbers, so we compose the node tree ourselves and record the line of each mapping key and
sequence item under its key path (a tuple of str / int).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

KeyPath = tuple[str | int, ...]


class YamlDocument:
    """A parsed YAML document plus the source line (1-based) of every key path."""

    def __init__(self, data: Any, lines: dict[KeyPath, int], path: Path | None) -> None:
        self.data = data
        self.lines = lines
        self.path = path

    def line_of(self, key_path: KeyPath) -> int | None:
        """Line of the longest prefix of ``key_path`` that the document defines."""
        for end in range(len(key_path), -1, -1):
            line = self.lines.get(tuple(key_path[:end]))
            if line is not None:
                return line
        return None


def _construct(node: yaml.Node, path: KeyPath, lines: dict[KeyPath, int]) -> Any:
    lines.setdefault(path, node.start_mark.line + 1)
    if isinstance(node, yaml.MappingNode):
        out: dict[Any, Any] = {}
        for key_node, value_node in node.value:
            key = _scalar(key_node)
            if isinstance(key, (list, dict)):
                raise yaml.constructor.ConstructorError(
                    None, None, "mapping keys must be scalars", key_node.start_mark
                )
            key_path = (*path, key)
            lines[key_path] = key_node.start_mark.line + 1
            out[key] = _construct(value_node, key_path, lines)
        return out
    if isinstance(node, yaml.SequenceNode):
        return [_construct(item, (*path, index), lines) for index, item in enumerate(node.value)]
    return _scalar(node)


def _scalar(node: yaml.Node) -> Any:
    """Resolve a node with the safe constructor (int, float, bool, null, str, ...)."""
    return yaml.SafeLoader("").construct_object(node, deep=True)


def parse_yaml(text: str, path: Path | None = None) -> YamlDocument:
    """Parse one YAML document; raises ``yaml.YAMLError`` on syntax errors."""
    node = yaml.compose(text, Loader=yaml.SafeLoader)
    lines: dict[KeyPath, int] = {}
    data = None if node is None else _construct(node, (), lines)
    return YamlDocument(data, lines, path)


def format_key_path(key_path: KeyPath) -> str:
    """``("objects", 0, "mass")`` -> ``objects[0].mass``."""
    text = ""
    for part in key_path:
        if isinstance(part, int):
            text += f"[{part}]"
        else:
            text += f".{part}" if text else str(part)
    return text or "<root>"
