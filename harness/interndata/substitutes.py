"""Object substitution (``--object NAME=PATH[@SCALE]``): parsing the command-line values."""

from __future__ import annotations

import math

from harness.config.errors import ConfigError


def parse_object_substitutions(items: list[str] | tuple[str, ...]) -> dict[str, str]:
    """``["NAME=PATH", "NAME=PATH@SCALE", ...]`` (``--object``) -> ``{NAME: value}``."""
    out: dict[str, str] = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name.strip() or not value.strip():
            raise ConfigError(f"--object {item!r}: expected NAME=PATH (or NAME=PATH@SCALE)")
        out[name.strip()] = value.strip()
    return out


def split_substitute(value: str) -> tuple[str, tuple[float, float, float] | None]:
    """``PATH`` or ``PATH@S`` / ``PATH@SX,SY,SZ`` -> (path, scale or None)."""
    path, sep, suffix = value.rpartition("@")
    if not sep:
        return value, None
    try:
        numbers = [float(part) for part in suffix.split(",")]
    except ValueError:
        return value, None  # an '@' that belongs to the path
    if len(numbers) == 1:
        numbers *= 3
    if len(numbers) != 3 or not all(math.isfinite(n) and n > 0 for n in numbers):
        raise ConfigError(f"--object {value!r}: scale must be one or three positive numbers")
    return path, (numbers[0], numbers[1], numbers[2])
