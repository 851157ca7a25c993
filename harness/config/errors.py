"""Configuration errors: ``ConfigError`` (one located line) and ``KeyedValueError``.

Every configuration problem reaches the user as one ``ConfigError`` line,
``file:line key.path: message``. Model validators raise ``KeyedValueError`` to name the key a
cross-key failure is about, so that line points at that key.
"""

from __future__ import annotations

from pathlib import Path

from harness.config.yamlio import KeyPath
from harness.errors import HarnessError


class ConfigError(HarnessError, ValueError):
    """A configuration problem, located by file, line and key path when known."""

    def __init__(
        self,
        message: str,
        *,
        file: str | Path | None = None,
        line: int | None = None,
        key: str | None = None,
    ) -> None:
        self.message = message
        self.file = str(file) if file is not None else None
        self.line = line
        self.key = key
        super().__init__(self.one_line())

    def one_line(self) -> str:
        """``file:line key.path: message`` with whatever parts are known."""
        where = ""
        if self.file:
            where = self.file + (f":{self.line}" if self.line else "")
        if self.key:
            where = f"{where} {self.key}" if where else self.key
        text = f"{where}: {self.message}" if where else self.message
        return text.replace("\r", "\\r").replace("\n", "\\n")  # always exactly one line

    def with_file(self, file: str | Path | None) -> ConfigError:
        """The same error attributed to ``file`` when it has no file yet."""
        if file and not self.file:
            return ConfigError(self.message, file=file, line=self.line, key=self.key)
        return self


class KeyedValueError(ValueError):
    """A cross-key validation failure that names the key it is about.

    A model validator sees the whole model, so pydantic locates its errors at the model itself;
    raising this instead lets ``error_from_validation`` point at ``key`` (relative to the model),
    so the one-line error carries the key path and that key's line.
    """

    def __init__(self, key: str | KeyPath, message: str) -> None:
        super().__init__(message)
        self.key: KeyPath = (key,) if isinstance(key, str) else tuple(key)
