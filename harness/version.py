"""The installed version of pick-harness (a leaf module, so any module can name it)."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("pick-harness")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+source"
