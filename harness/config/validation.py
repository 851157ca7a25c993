"""Pydantic validation errors -> one located ``ConfigError`` line.

``validate_model`` validates data as a model and reports the first problem as
``file:line key.path: message``, suggesting the closest key for a misspelt one.
"""

from __future__ import annotations

from typing import Any, TypeVar

from pydantic import BaseModel, ValidationError

from harness.config.errors import ConfigError, KeyedValueError
from harness.config.messages import short_repr, suggest
from harness.config.yamlio import KeyPath, YamlDocument, format_key_path


def _model_at(model: type[BaseModel], loc: tuple[Any, ...]) -> type[BaseModel] | None:
    """Follow a pydantic error location through nested models, for key suggestions."""
    current: Any = model
    for part in loc:
        if isinstance(part, int) or not isinstance(current, type):
            continue
        if not issubclass(current, BaseModel):
            return None
        field = current.model_fields.get(str(part))
        if field is None:
            continue
        annotation = field.annotation
        current = _innermost_model(annotation)
        if current is None:
            return None
    return current if isinstance(current, type) and issubclass(current, BaseModel) else None


def _innermost_model(annotation: Any) -> type[BaseModel] | None:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for arg in getattr(annotation, "__args__", ()) or ():
        found = _innermost_model(arg)
        if found is not None:
            return found
    return None


def _clean_loc(loc: tuple[Any, ...]) -> KeyPath:
    """Drop pydantic's union / function tags from a location, keep keys and indices."""
    out: list[str | int] = []
    for part in loc:
        tag = isinstance(part, str) and (
            part.startswith(("function-", "tagged-union", "json-or-python"))
            or part in {"AxisFilter", "str", "dict[str,any]", "list[str]", "none"}
            or "[" in part
        )
        if isinstance(part, (int, str)) and not tag:
            out.append(part)
    return tuple(out)


def describe_validation_error(
    exc: ValidationError, model: type[BaseModel]
) -> tuple[KeyPath, str, KeyPath]:
    """The first pydantic error as ``(key path, message, path to take the line from)``.

    Key paths are relative to ``model``. Used by ``error_from_validation`` and by loaders whose
    model keys come from other places in a file (``harness.interndata.mapper``).
    """
    errors = exc.errors(include_url=False)
    err = errors[0]
    if err.get("type") == "missing":
        # A misspelt key shows up as "missing" plus "extra"; the extra one explains both.
        parent = tuple(err.get("loc", ()))[:-1]
        for other in errors:
            if other.get("type") == "extra_forbidden" and tuple(other["loc"])[:-1] == parent:
                err = other
                break
    loc = _clean_loc(tuple(err.get("loc", ())))
    cause = (err.get("ctx") or {}).get("error")
    if isinstance(cause, KeyedValueError):
        loc = (*loc, *cause.key)
    message = str(err.get("msg", "invalid value"))
    if message.startswith("Value error, "):
        message = message[len("Value error, ") :]
    line_loc: KeyPath | None = None
    if err.get("type") == "extra_forbidden" and loc:
        parent = _model_at(model, loc[:-1]) or model
        message = f"unknown key{suggest(str(loc[-1]), parent.model_fields)}"
    elif err.get("type") == "invalid_key":
        # YAML read a key as a non-string (1, null, a date); pydantic stringifies it in loc.
        bad_key = err.get("input")
        loc = loc[:-1]
        line_loc = (*loc, bad_key)
        message = (
            f"key {bad_key!r} is a {type(bad_key).__name__}, keys must be strings "
            "(quote it, or fix the name)"
        )
    elif err.get("type") == "missing" and loc and isinstance(loc[-1], int):
        message = f"too few values: item [{loc[-1]}] is missing"  # a short tuple
        loc = loc[:-1]
    elif err.get("type") == "missing":
        message = "required key is missing"
    elif "input" in err and err.get("type") not in ("value_error", "assertion_error"):
        message = f"{message} (got {short_repr(err['input'])})"
    return loc, message, line_loc if line_loc is not None else loc


def error_from_validation(
    exc: ValidationError,
    model: type[BaseModel],
    doc: YamlDocument | None = None,
    prefix: KeyPath = (),
) -> ConfigError:
    """Turn the first pydantic error into a located one-line ConfigError."""
    loc, message, line_loc = describe_validation_error(exc, model)
    full = (*prefix, *loc)
    line = doc.line_of((*prefix, *line_loc)) if doc is not None else None
    file = doc.path if doc is not None else None
    return ConfigError(message, file=file, line=line, key=format_key_path(full) if full else None)


M = TypeVar("M", bound=BaseModel)


def validate_model(
    model: type[M], data: Any, doc: YamlDocument | None = None, prefix: KeyPath = ()
) -> M:
    """Validate ``data`` as ``model``; failures become a located ConfigError."""
    if not isinstance(data, dict):
        where = format_key_path(prefix) if prefix else None
        raise ConfigError(
            f"expected a mapping of {model.__name__} keys, got {type(data).__name__}",
            file=doc.path if doc else None,
            line=doc.line_of(prefix) if doc else None,
            key=where,
        )
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise error_from_validation(exc, model, doc, prefix) from None
