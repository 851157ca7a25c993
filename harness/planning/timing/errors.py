"""Time parameterisation failures."""

from __future__ import annotations


class TimingError(RuntimeError):
    """Time parameterisation failed (the planner reports it as ``plan_failed``)."""

    def __init__(self, message: str, return_code: object = None) -> None:
        self.return_code = return_code
        super().__init__(message if return_code is None else f"{message} (code {return_code})")
