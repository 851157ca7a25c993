"""How to open a Rerun recording, as commands that run as printed: one source for ``harness
view`` (which opens it, or prints these without a display) and report.html (which prints them
beside its recordings), so both say the same thing.

The ``rerun`` binary of the installed rerun-sdk sits beside this interpreter (a venv's
``bin/``), which is often not on PATH (under nox), so the commands name it by its full path;
without it, ``python -m rerun`` with this interpreter. Its server listens on loopback only.
"""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path


def rerun_viewer() -> str | None:
    """The ``rerun`` binary of the installed rerun-sdk: beside this interpreter, else on PATH;
    None without it."""
    beside = Path(sys.executable).parent / ("rerun.exe" if sys.platform == "win32" else "rerun")
    if beside.is_file() and os.access(beside, os.X_OK):
        return str(beside)
    return shutil.which("rerun")


def native_command(path: Path | str, viewer: str | None) -> str:
    """The viewer on a machine with a display: ``/venv/bin/rerun PATH``."""
    return f"{viewer or f'{sys.executable} -m rerun'} {path}"


def web_command(path: Path | str, viewer: str | None) -> str:
    """The recording served to a browser: ``/venv/bin/rerun --bind 127.0.0.1 --web-viewer
    PATH`` (it prints the address to open)."""
    return f"{viewer or f'{sys.executable} -m rerun'} --bind 127.0.0.1 --web-viewer {path}"
