"""OmegaConf-style ``${...}`` interpolation over a whole InternDataEngine document.

The reference resolves its files with ``OmegaConf.to_container(resolve=True)``; this does the
same over plain YAML data, and a broken interpolation is an error naming its key.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from harness.config.messages import suggest
from harness.config.yamlio import KeyPath, YamlDocument, format_key_path
from harness.interndata.errors import Located

_MISSING = object()


class InterpolationResolver:
    """OmegaConf-style ``${...}`` interpolation over plain YAML data.

    Supported: absolute dotted paths with list indices (``tasks.0.robots.0.name`` or
    ``tasks[0].robots[0].name``), relative paths (``${.sibling}``, ``${..uncle}``), nested
    interpolations in the key (``${a.${b}}``), interpolations whose target is itself interpolated,
    ``\\${`` for a literal ``${``. A string that is exactly one interpolation takes the target's
    value and type; otherwise targets are formatted into the string. Resolvers (``${oc.env:X}``)
    are not supported.
    """

    def __init__(self, root: Any, where: Located) -> None:
        self.root = root
        self.where = where
        self.active: list[KeyPath] = []  # strings being resolved, to catch cycles

    def resolve(self, node: Any, path: KeyPath = ()) -> Any:
        if isinstance(node, dict):
            return {key: self.resolve(value, (*path, key)) for key, value in node.items()}
        if isinstance(node, list):
            return [self.resolve(value, (*path, index)) for index, value in enumerate(node)]
        if isinstance(node, str) and "${" in node:
            return self._string(node, path)
        return node

    def _string(self, text: str, path: KeyPath) -> Any:
        if path in self.active:
            cycle = " -> ".join(format_key_path(p) for p in [*self.active, path])
            raise self.where.error(path, f"interpolation cycle: {cycle}")
        self.active.append(path)
        try:
            pieces = self._split(text, path)
            if len(pieces) == 1 and isinstance(pieces[0], tuple):
                return self._lookup(pieces[0][0], path)
            out = []
            for piece in pieces:
                if isinstance(piece, str):
                    out.append(piece)
                    continue
                value = self._lookup(piece[0], path)
                if isinstance(value, (dict, list)):
                    raise self.where.error(
                        path,
                        f"interpolation ${{{piece[0]}}} is a {type(value).__name__}; "
                        "only a whole string can take a mapping or list",
                    )
                out.append(str(value))
            return "".join(out)
        finally:
            self.active.pop()

    def _split(self, text: str, path: KeyPath) -> list[str | tuple[str]]:
        """Literal text and ``(expression,)`` pieces; nested ``${}`` inside an expression are
        resolved to text first."""
        pieces: list[str | tuple[str]] = []
        literal = ""
        index = 0
        while index < len(text):
            if text.startswith("\\${", index):
                literal += "${"
                index += 3
            elif text.startswith("${", index):
                end, expression = self._expression(text, index + 2, path)
                if literal:
                    pieces.append(literal)
                    literal = ""
                pieces.append((expression,))
                index = end
            else:
                literal += text[index]
                index += 1
        if literal:
            pieces.append(literal)
        return pieces

    def _expression(self, text: str, start: int, path: KeyPath) -> tuple[int, str]:
        """Read up to the matching ``}``; returns (index after it, expression with inner
        interpolations resolved)."""
        out = ""
        index = start
        while index < len(text):
            if text.startswith("${", index):
                end, inner = self._expression(text, index + 2, path)
                value = self._lookup(inner, path)
                if isinstance(value, (dict, list)):
                    raise self.where.error(path, f"nested interpolation ${{{inner}}} is not a key")
                out += str(value)
                index = end
            elif text[index] == "}":
                return index + 1, out.strip()
            else:
                out += text[index]
                index += 1
        raise self.where.error(path, f"unterminated interpolation in {text!r} (missing '}}')")

    def _lookup(self, expression: str, path: KeyPath) -> Any:
        if not expression:
            raise self.where.error(path, "empty interpolation ${}")
        if ":" in expression:
            name = expression.split(":", 1)[0]
            raise self.where.error(
                path, f"interpolation ${{{expression}}}: resolver {name!r} is not supported"
            )
        dots = len(expression) - len(expression.lstrip("."))
        body = expression[dots:]
        if dots:  # relative: one dot is the node holding this string, each more goes up
            base: KeyPath = path[: max(0, len(path) - dots)]
        else:
            base = ()
        parts = [p for p in re.split(r"\.|\[|\]", body) if p != ""] if body else []
        if (body and not parts) or re.search(r"\.\.|\[\]", body):
            raise self.where.error(path, f"interpolation ${{{expression}}} is not a key path")
        node: Any = self.root
        walked: list[str | int] = []
        for step in (*base, *parts):
            value = self._child(node, step)
            if value is _MISSING:
                if isinstance(node, list) and str(step).lstrip("-").isdigit():
                    step = int(step)
                shown = format_key_path((*walked, step))
                raise self.where.error(
                    path,
                    f"interpolation ${{{expression}}}: key {shown!r} not found"
                    f"{self._hint(node, step)}",
                )
            walked.append(int(step) if isinstance(node, list) else step)
            node = value
        target = tuple(walked)
        if isinstance(node, str) and "${" in node:
            return self._string(node, target)
        return self.resolve(node, target)

    @staticmethod
    def _child(node: Any, step: str | int) -> Any:
        if isinstance(node, dict):
            if step in node:
                return node[step]
            if isinstance(step, str) and step.lstrip("-").isdigit() and int(step) in node:
                return node[int(step)]
            return _MISSING
        if isinstance(node, list):
            try:
                index = int(step)
            except ValueError:
                return _MISSING
            return node[index] if 0 <= index < len(node) else _MISSING
        return _MISSING

    @staticmethod
    def _hint(node: Any, step: str | int) -> str:
        if isinstance(node, dict):
            return suggest(str(step), [str(k) for k in node]) or f" (keys: {list(node)[:8]})"
        if isinstance(node, list):
            return f" (the list has {len(node)} items)"
        return f" ({type(node).__name__} has no keys)"


def resolve_interpolations(doc: YamlDocument, file: str | Path | None = None) -> Any:
    """The document's data with every ``${...}`` resolved (see ``InterpolationResolver``)."""
    where = Located(doc, str(file if file is not None else doc.path))
    return InterpolationResolver(doc.data, where).resolve(doc.data)
