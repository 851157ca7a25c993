"""pick-harness: which grasp-filter settings make InternDataEngine-style picks succeed.

The Python API (``harness.load_task``, ``harness.run_episode``, ``harness.sweep``,
``harness.load_run``; docs/python.md) is imported on first use, so ``import harness`` and the
command line stay light.
"""

from typing import TYPE_CHECKING, Any

from harness.version import __version__

if TYPE_CHECKING:  # what the lazy attributes below resolve to
    from harness.api import load_run, load_task, run_episode, sweep

API = ("load_task", "run_episode", "sweep", "load_run")
__all__ = ["__version__", "load_run", "load_task", "run_episode", "sweep"]


def __getattr__(name: str) -> Any:
    if name in API:
        from harness import api

        return getattr(api, name)
    raise AttributeError(f"module 'harness' has no attribute {name!r}")


def __dir__() -> list[str]:
    """``dir(harness)`` lists the API, although its functions are imported on first use."""
    return sorted({*globals(), *__all__})
