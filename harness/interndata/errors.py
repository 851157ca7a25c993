"""Located errors against one InternDataEngine document."""

from __future__ import annotations

from harness.config.errors import ConfigError
from harness.config.yamlio import KeyPath, YamlDocument, format_key_path


class Located:
    """Raise located ConfigErrors against one document."""

    def __init__(self, doc: YamlDocument, file: str) -> None:
        self.doc = doc
        self.file = file

    def error(self, path: KeyPath, message: str, line_path: KeyPath | None = None) -> ConfigError:
        line = self.doc.line_of(line_path if line_path is not None else path)
        key = format_key_path(path) if path else None
        return ConfigError(message, file=self.file, line=line, key=key)
