"""Reading task and sweep YAML files; any I/O, syntax or model problem is a ``ConfigError``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml
from pydantic import BaseModel

from harness.config.errors import ConfigError
from harness.config.sweep import SweepConfig
from harness.config.task import TaskConfig
from harness.config.validation import validate_model
from harness.config.yamlio import YamlDocument, parse_yaml
from harness.files import MAX_CONFIG_BYTES, RefusedFileError, read_capped

MAX_YAML_BYTES = MAX_CONFIG_BYTES


def read_yaml(path: str | Path) -> YamlDocument:
    """Read and parse a YAML file; any I/O or syntax problem becomes a ConfigError."""
    path = Path(path)
    return parse_text(read_text_file(path), path)


def read_text_file(path: Path, max_bytes: int = MAX_YAML_BYTES) -> str:
    """The UTF-8 text of a config file: a regular file read with a hard byte cap (a FIFO, a
    device or a link to ``/dev/zero`` is refused at once); problems are ConfigErrors."""
    try:
        data = read_capped(path, max_bytes)
        return data.decode("utf-8")
    except FileNotFoundError:
        raise ConfigError("file not found", file=path) from None
    except RefusedFileError as exc:
        if exc.too_large:
            message = f"{exc}: too large for a task or sweep file; is this the right file?"
        else:  # a FIFO or a device would block or never end: refused before any read
            message = f"cannot read file: it {exc}"
        raise ConfigError(message, file=path) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read file: {exc}", file=path) from None


def parse_text(text: str, path: str | Path | None = None) -> YamlDocument:
    """Parse YAML text; syntax errors become ConfigErrors with the line."""
    try:
        return parse_yaml(text, Path(path) if path is not None else None)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = mark.line + 1 if mark is not None else None
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        context = getattr(exc, "context", None)
        if context and not context.startswith("while "):  # e.g. "expected a single document"
            problem = f"{context}, {problem}"
        raise ConfigError(f"invalid YAML: {problem}", file=path, line=line) from None
    except (RecursionError, ValueError, TypeError) as exc:  # pathological documents
        raise ConfigError(f"invalid YAML: {exc}", file=path) from None


def kind_of(data: Any) -> str:
    """Guess what a YAML document is: 'sweep', 'task' or 'interndata'."""
    if isinstance(data, dict):
        if "tasks" in data and isinstance(data["tasks"], list):
            first = data["tasks"][0] if data["tasks"] else None
            if isinstance(first, dict) and ("skills" in first or "robots" in first):
                return "interndata"
            return "sweep"
        if "robot" in data or "pick" in data:
            return "task"
    return "unknown"


_INTERNDATA = "this is an InternDataEngine task file; use `harness run --interndata {path}`"
WRONG_KIND_HINTS = {
    ("task", "sweep"): "this is a sweep file; run it with `harness sweep {path}`",
    ("task", "interndata"): _INTERNDATA,
    ("sweep", "task"): "this is a task file; run it with `harness run {path}`",
    ("sweep", "interndata"): _INTERNDATA + " or list it in a sweep's tasks",
}


def _check_kind(doc: YamlDocument, expected: str, path: str | Path) -> None:
    """A task file given where a sweep is expected (or the other way round) says so."""
    hint = WRONG_KIND_HINTS.get((expected, kind_of(doc.data)))
    if hint is not None:
        raise ConfigError(hint.format(path=path), file=path)


def load_task(path: str | Path) -> TaskConfig:
    """Load a harness task YAML."""
    doc = read_yaml(path)
    _check_kind(doc, "task", path)
    data = doc.data
    if isinstance(data, dict):
        data = {**data, "source": str(Path(path))}
    return validate_model(TaskConfig, data, doc)


def load_sweep(path: str | Path) -> SweepConfig:
    """Load a sweep YAML (the tasks it lists are loaded when the sweep expands)."""
    doc = read_yaml(path)
    _check_kind(doc, "sweep", path)
    return validate_model(SweepConfig, doc.data, doc)


def load_any(path: str | Path) -> tuple[str, BaseModel | YamlDocument]:
    """Load a task or sweep YAML by sniffing its top-level keys (used by ``harness validate``)."""
    doc = read_yaml(path)
    kind = kind_of(doc.data)
    if kind == "sweep":
        return kind, validate_model(SweepConfig, doc.data, doc)
    if kind == "task":
        data = {**doc.data, "source": str(Path(path))}
        return kind, validate_model(TaskConfig, data, doc)
    if kind == "interndata":
        return kind, doc
    raise ConfigError(
        "not a task (needs 'robot' and 'objects') or a sweep (needs 'name' and 'tasks')",
        file=path,
        line=1,
    )
