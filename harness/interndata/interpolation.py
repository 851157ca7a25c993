"""``${...}`` interpolation over a whole InternDataEngine document, resolved by OmegaConf.

The reference resolves its files with ``OmegaConf.to_container(resolve=True)``, and so does
``resolve_interpolations``, after a guard pass: ``InterpolationResolver`` walks the same
interpolations first, with bounds (chain depth, string length, node count) that OmegaConf does
not have (an interpolation bomb made it build a 2^34-character string, a 3,000-deep chain
overflowed the stack) and errors that name the key (missing key with a suggestion, cycle,
unsupported resolver such as ``${oc.env:X}``, which would read the environment). Only a document
the guard passes reaches OmegaConf; a difference between the two is an error naming the key.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from harness.config.messages import suggest
from harness.config.yamlio import KeyPath, YamlDocument, format_key_path
from harness.interndata.errors import Located

_MISSING = object()
# Bounds on what interpolation may build (chosen, no public source: the example files resolve
# to a few hundred nodes and strings under 200 characters). Without them ``'${x.l0}${x.l0}'``
# over 34 levels asked for a 2^34-character string, 40 levels of lists for 2^40 nodes, and a
# chain of 3,000 references overflowed the stack: each hung or crashed `harness validate`.
MAX_CHAIN = 100  # interpolations resolved inside one another
MAX_STRING_CHARS = 65_536  # one resolved string
MAX_NODES = 200_000  # the resolved document, counted as a tree (as harness.config.yamlio)


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
        self.done: dict[KeyPath, Any] = {}  # resolved nodes: each is resolved once
        self.sizes: dict[int, int] = {}  # id(resolved container) -> its node count as a tree

    def resolve(self, node: Any, path: KeyPath = ()) -> Any:
        if path in self.done:
            return self.done[path]
        if isinstance(node, dict):
            out: Any = {key: self.resolve(value, (*path, key)) for key, value in node.items()}
            self._count(out, out.values(), path)
        elif isinstance(node, list):
            out = [self.resolve(value, (*path, index)) for index, value in enumerate(node)]
            self._count(out, out, path)
        elif isinstance(node, str) and "${" in node:
            out = self._string(node, path)
        else:
            out = node
        self.done[path] = out
        return out

    def _size(self, value: Any) -> int:
        return self.sizes.get(id(value), 1) if isinstance(value, (dict, list)) else 1

    def _count(self, container: Any, children: Any, path: KeyPath) -> None:
        """Record the container's node count as a tree (shared targets counted each time
        they appear), refusing documents that would expand past ``MAX_NODES``."""
        size = 1 + sum(self._size(child) for child in children)
        if size > MAX_NODES:
            raise self.where.error(
                path,
                f"interpolation expands this node to more than {MAX_NODES:,} nodes "
                "(an interpolation bomb?)",
            )
        self.sizes[id(container)] = size

    def _string(self, text: str, path: KeyPath) -> Any:
        if path in self.active:
            cycle = " -> ".join(format_key_path(p) for p in [*self.active, path])
            raise self.where.error(path, f"interpolation cycle: {cycle}")
        if len(self.active) >= MAX_CHAIN:
            raise self.where.error(
                path, f"interpolations nest more than {MAX_CHAIN} deep (each refers to the next)"
            )
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
                if sum(map(len, out)) > MAX_STRING_CHARS:
                    raise self.where.error(
                        path,
                        f"interpolation builds a string longer than {MAX_STRING_CHARS:,} "
                        "characters (an interpolation bomb?)",
                    )
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
        return self.resolve(node, tuple(walked))

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
    guarded = _tree_copy(InterpolationResolver(doc.data, where).resolve(doc.data))
    return _omegaconf_resolve(doc.data, guarded, where)


def _omegaconf_resolve(data: Any, guarded: Any, where: Located) -> Any:
    """``OmegaConf.to_container(OmegaConf.create(data), resolve=True)`` as the reference does;
    where OmegaConf cannot hold the plain YAML data (non-string keys, dates) or the two disagree,
    the error names the first key that differs."""
    from omegaconf import OmegaConf
    from omegaconf.errors import OmegaConfBaseException

    if not isinstance(data, dict):
        return guarded
    try:
        resolved = OmegaConf.to_container(OmegaConf.create(data), resolve=True)
    except (OmegaConfBaseException, RecursionError, ValueError, TypeError) as exc:
        key = getattr(exc, "full_key", None)
        path = _key_path(str(key)) if key else ()
        detail = str(exc).strip().splitlines()[0][:200]
        raise where.error(path, f"OmegaConf cannot resolve the file: {detail}") from None
    if resolved != guarded:
        path = _first_difference(resolved, guarded, ())
        raise where.error(
            path, "OmegaConf and the harness's interpolation guard resolve this key differently"
        )
    return resolved


def _key_path(key: str) -> KeyPath:
    """OmegaConf's ``full_key`` (``tasks[0].robots[1].name``) as a key path."""
    parts: list[str | int] = []
    for piece in re.findall(r"[^.\[\]]+", key):
        parts.append(int(piece) if piece.isdigit() else piece)
    return tuple(parts)


def _first_difference(a: Any, b: Any, path: KeyPath) -> KeyPath:
    if isinstance(a, dict) and isinstance(b, dict):
        for key in a:
            if key not in b or a[key] != b[key]:
                return _first_difference(a[key], b.get(key), (*path, key))
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for index, (x, y) in enumerate(zip(a, b, strict=True)):
            if x != y:
                return _first_difference(x, y, (*path, index))
    return path


def _tree_copy(value: Any) -> Any:
    """A copy in which no container is shared (the resolver hands one resolved target to
    every reference; its size is bounded by ``MAX_NODES``, so the copy is too)."""
    if isinstance(value, dict):
        return {key: _tree_copy(item) for key, item in value.items()}
    if isinstance(value, list):
        return [_tree_copy(item) for item in value]
    return value
