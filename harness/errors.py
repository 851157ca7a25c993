"""Project error types. The CLI prints any ``HarnessError`` as one line and exits non-zero."""

from __future__ import annotations


class HarnessError(Exception):
    """Base class for errors caused by user input (files, configs, names), not by bugs."""


class InputFileError(HarnessError, ValueError):
    """A data file (grasp file, mesh, robot description) that cannot be used, with the reason."""

    def __init__(self, file: object, message: str, key: str | None = None) -> None:
        self.file = str(file)
        self.message = message
        self.key = key
        where = f"{self.file} {key}" if key else self.file
        super().__init__(f"{where}: {message}")


class DiskFullError(HarnessError):
    """The disk under a run directory is full: the run stops, every stored row is kept."""


class EpisodeTimeoutError(HarnessError):
    """An episode reached its wall-clock limit or its simulated-step budget (``timeout``)."""
