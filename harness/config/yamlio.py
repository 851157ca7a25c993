"""YAML loading that remembers where every key came from.

Config errors must point at ``file:line key.path``; PyYAML's plain ``safe_load`` forgets line
numbers, so we compose the node tree ourselves and record the line of each mapping key and
sequence item under its key path (a tuple of str / int).

The result matches ``yaml.safe_load`` (merge keys ``<<: *anchor`` included) except that it is
stricter where silence would hide mistakes: duplicate keys, recursive aliases and documents that
expand past ``MAX_NODES`` nodes are errors (``yaml.YAMLError``, located by line).
"""

from __future__ import annotations

from collections.abc import Callable
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


MERGE_TAG = "tag:yaml.org,2002:merge"


def _check_mapping(node: yaml.MappingNode, scalar: Callable[[yaml.Node], Any]) -> None:
    """Reject duplicate keys (YAML forbids them; PyYAML would silently keep the last one)
    and expand ``<<: *anchor`` merge keys the way PyYAML's ``safe_load`` does."""
    seen: dict[Any, int] = {}
    for key_node, _ in node.value:
        if key_node.tag == MERGE_TAG:
            continue
        key = scalar(key_node)
        try:
            first = seen.get(key)
        except TypeError:  # unhashable key; reported when the mapping is built
            continue
        if first is not None:
            raise yaml.constructor.ConstructorError(
                None, None, f"duplicate key {key!r} (first on line {first})", key_node.start_mark
            )
        seen[key] = key_node.start_mark.line + 1
    if any(key_node.tag == MERGE_TAG for key_node, _ in node.value):
        yaml.SafeLoader("").flatten_mapping(node)


# The tags plain YAML data resolves to; anything else (``!!python/object/apply:...``, custom
# ``!tags``) is an error rather than silently dropped.
SAFE_TAGS = frozenset(
    f"tag:yaml.org,2002:{name}"
    for name in ("str", "int", "float", "bool", "null", "map", "seq", "merge", "timestamp")
)
MAX_NODES = 200_000  # aliases can expand exponentially ("billion laughs"); stop well before


class _Builder:
    """Builds Python data from a composed node tree, recording the line of every key path."""

    def __init__(self) -> None:
        self.lines: dict[KeyPath, int] = {}
        self.nodes = 0
        self.active: set[int] = set()  # nodes being built, to catch recursive aliases
        self.constructor = yaml.constructor.SafeConstructor()

    def scalar(self, node: yaml.Node) -> Any:
        """Resolve a scalar node with the safe constructor (int, float, bool, null, str, ...)."""
        return self.constructor.construct_object(node, deep=True)

    def build(self, node: yaml.Node, path: KeyPath) -> Any:
        self.nodes += 1
        if self.nodes > MAX_NODES:
            raise yaml.constructor.ConstructorError(
                None, None, f"document expands to more than {MAX_NODES} nodes", node.start_mark
            )
        self.lines.setdefault(path, node.start_mark.line + 1)
        if node.tag not in SAFE_TAGS:
            raise yaml.constructor.ConstructorError(
                None, None, f"unsupported YAML tag {node.tag!r} (plain data only)", node.start_mark
            )
        if not isinstance(node, (yaml.MappingNode, yaml.SequenceNode)):
            return self.scalar(node)
        if id(node) in self.active:
            raise yaml.constructor.ConstructorError(
                None, None, "recursive alias (a node that contains itself)", node.start_mark
            )
        self.active.add(id(node))
        try:
            if isinstance(node, yaml.SequenceNode):
                return [self.build(item, (*path, index)) for index, item in enumerate(node.value)]
            _check_mapping(node, self.scalar)
            out: dict[Any, Any] = {}
            for key_node, value_node in node.value:
                key = self.scalar(key_node)
                if isinstance(key, (list, dict)):
                    raise yaml.constructor.ConstructorError(
                        None, None, "mapping keys must be scalars", key_node.start_mark
                    )
                key_path = (*path, key)
                self.lines[key_path] = key_node.start_mark.line + 1
                out[key] = self.build(value_node, key_path)
            return out
        finally:
            self.active.discard(id(node))


def parse_yaml(text: str, path: Path | None = None) -> YamlDocument:
    """Parse one YAML document; raises ``yaml.YAMLError`` on syntax errors."""
    node = yaml.compose(text, Loader=yaml.SafeLoader)
    builder = _Builder()
    data = None if node is None else builder.build(node, ())
    return YamlDocument(data, builder.lines, path)


def format_key_path(key_path: KeyPath) -> str:
    """``("objects", 0, "mass")`` -> ``objects[0].mass``."""
    text = ""
    for part in key_path:
        if isinstance(part, int):
            text += f"[{part}]"
        elif not isinstance(part, str) or not part or not part.isprintable():
            text += f"[{part!r}]"  # an odd key ('', a newline, ...) stays visible and one-line
        else:
            text += f".{part}" if text else part
    return text or "<root>"
