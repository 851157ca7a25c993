"""``harness view FILE.rrd|RUN_DIR``: open a recording in the Rerun viewer, or say how to."""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
from pathlib import Path

from harness.errors import HarnessError


def has_display() -> bool:
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")) or (
        sys.platform in ("darwin", "win32")
    )


RRD_MAGIC = b"RRF"  # an .rrd stream starts with the FourCC RRF2 (rerun-sdk 0.41; RRF0/1 before)


def is_recording(path: Path) -> bool:
    """An ``.rrd`` file whose first bytes are Rerun's magic: anything else (a CSV, a text file)
    is refused instead of being handed to the viewer."""
    if path.suffix != ".rrd":
        return False
    try:
        with path.open("rb") as handle:
            return handle.read(len(RRD_MAGIC)) == RRD_MAGIC
    except OSError:
        return False


def main(args: argparse.Namespace) -> int:
    path = Path(args.file)
    if path.is_dir():  # a run directory: its sweep overview recording
        path = path / "recording.rrd"
    if not path.is_file():
        raise HarnessError(f"{path}: no such recording")
    if not is_recording(path):
        raise HarnessError(
            f"{path}: not a Rerun recording (expected an .rrd file starting with the Rerun "
            "magic bytes RRF; a run directory opens its recording.rrd)"
        )
    viewer = rerun_viewer()
    if has_display() and viewer:
        # Loopback only: the viewer's server must not listen on every interface.
        return subprocess.call([viewer, "--bind", "127.0.0.1", str(path)])
    for line in open_instructions(path, viewer):
        print(line)
    return 0


def rerun_viewer() -> str | None:
    """The ``rerun`` binary of the installed rerun-sdk: beside this interpreter (a venv's
    ``bin/``, which is often not on PATH, e.g. under nox), else on PATH; None without it."""
    beside = Path(sys.executable).parent / ("rerun.exe" if sys.platform == "win32" else "rerun")
    if beside.is_file() and os.access(beside, os.X_OK):
        return str(beside)
    return shutil.which("rerun")


def open_instructions(path: Path, viewer: str | None) -> list[str]:
    """How to open ``path`` without a display here: commands that run as printed (the viewer
    binary by its full path, or ``python -m rerun`` with this interpreter), a browser option."""
    python = sys.executable
    native = viewer or f"{python} -m rerun"
    lines = [f"no display here; to look at {path}:"]
    if viewer is None:
        lines.append(f"  - install the viewer: {python} -m pip install 'rerun-sdk==0.41.*'")
    lines.append(f"  - on a machine with a display: {native} {path}")
    if viewer is not None:
        lines.append(f"    (or: {python} -m rerun {path})")
    return [
        *lines,
        f"  - or serve it to a browser:     {native} --bind 127.0.0.1 --web-viewer {path}",
        "  - or drag the file onto https://rerun.io/viewer (version 0.41)",
    ]
