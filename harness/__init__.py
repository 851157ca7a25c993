"""pick-harness: which grasp-filter settings make InternDataEngine-style picks succeed."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("pick-harness")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+source"

__all__ = ["__version__"]
