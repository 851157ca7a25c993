"""Set one-line YAML values in place, changing only their lines.

A tuned or generated copy of a task file must differ from its original only in the lines it
sets (``harness tune --write``: the filter lines; ``harness objects tasks``: the object's
``path``, ``category`` and ``task_dir``), whatever the file's indentation style: a round trip
through a YAML dumper reflows InternDataEngine's ``-`` / newline / mapping lists and its
comments. So the file is parsed once (ruamel.yaml round-trip mode, for each key's line and
column) and the text is edited line by line: a value is replaced from its column to its end (a
trailing comment stays), a new key is inserted after the mapping's last key at the mapping's
indentation, a removed key's line is dropped. Values must fit on one line (a scalar or a flow
list), which is what these keys hold.
"""

from __future__ import annotations

import json
from typing import Any

from ruamel.yaml import YAML
from ruamel.yaml.comments import CommentedMap, CommentedSeq

from harness.errors import HarnessError

KeyPath = tuple[str | int, ...]


def parse_key_path(text: str) -> KeyPath:
    """``tasks[0].skills[0].franka[0].left[0]`` -> ``("tasks", 0, "skills", 0, ...)``."""
    parts: list[str | int] = []
    for piece in text.replace("]", "").split("."):
        name, *indices = piece.split("[")
        if name:
            parts.append(name)
        parts.extend(int(i) for i in indices)
    return tuple(parts)


def flow_text(value: Any, quoted: bool = True) -> str:
    """A one-line YAML text of ``value``: a flow list, a string (quoted, or plain as the file
    writes its own) or a number."""
    if isinstance(value, list):
        return "[" + ", ".join(flow_text(v, quoted) for v in value) + "]"
    if isinstance(value, str):
        plain = value.replace("_", "").isalnum()
        return value if plain and not quoted else json.dumps(value)
    if isinstance(value, float) and value.is_integer():
        return str(int(value))
    return json.dumps(value)


def _value_end(line: str, start: int) -> int:
    """Where the value starting at ``start`` ends (before a trailing comment)."""
    text = line[start:]
    if text.startswith("["):
        depth = 0
        for i, ch in enumerate(text):
            depth += ch == "["
            depth -= ch == "]"
            if depth == 0:
                return start + i + 1
    if text[:1] in ('"', "'"):
        close = text.find(text[0], 1)
        return start + close + 1 if close > 0 else len(line)
    comment = text.find(" #")
    return start + (comment if comment >= 0 else len(text.rstrip("\n")))


def _node(data: Any, path: KeyPath, where: str) -> CommentedMap:
    node = data
    for part in path:
        try:
            node = node[part]
        except (KeyError, IndexError, TypeError):
            raise HarnessError(f"{where}: no key {part!r} at {path}") from None
    if not isinstance(node, CommentedMap):
        raise HarnessError(f"{where}: {path} is not a mapping")
    return node


def _same(old: Any, new: Any) -> bool:
    """Whether a parsed value equals ``new`` (a flow list elementwise; 90 == 90.0)."""
    return (list(old) if isinstance(old, list) else old) == new


def set_values(text: str, edits: dict[KeyPath, dict[str, Any | None]], where: str = "file") -> str:
    """``text`` with, for each mapping at a key path, its keys set (``None``: removed)."""
    data = YAML().load(text)
    lines = text.splitlines(keepends=True)
    changes: list[tuple[int, str, str | None]] = []  # (line, kind, new text)
    for path, keys in edits.items():
        block = _node(data, path, where)
        for key, value in keys.items():
            if key in block:
                line, col = block.lc.value(key)
                if isinstance(block[key], CommentedMap | CommentedSeq) and not (
                    isinstance(block[key], CommentedSeq) and lines[line][col:].startswith("[")
                ):
                    raise HarnessError(f"{where}: key {key!r} at {path}: not a one-line value")
                if value is None:
                    changes.append((line, "drop", None))
                    continue
                if _same(block[key], value):
                    continue  # the value it already holds: its line stays as written
                old = lines[line]
                end = _value_end(old, col)
                quoted = '"' in old[col:end] or "'" in old[col:end]
                changes.append((line, "set", old[:col] + flow_text(value, quoted) + old[end:]))
            elif value is not None:
                last = list(block)[-1]
                line, _ = block.lc.value(last)
                indent = block.lc.key(next(iter(block)))[1]
                quoted = any('"' in lines[block.lc.value(k)[0]] for k in block)
                new_line = " " * indent + f"{key}: {flow_text(value, quoted)}\n"
                changes.append((line, "after", new_line))
    for line, kind, new in sorted(changes, key=lambda c: -c[0]):
        if kind == "set":
            lines[line] = str(new)
        elif kind == "drop":
            del lines[line]
        else:
            if not lines[line].endswith("\n"):
                lines[line] += "\n"
            lines.insert(line + 1, str(new))
    return "".join(lines)
