"""``harness view FILE.rrd|RUN_DIR``: open a recording in the Rerun viewer, or say how to."""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
from pathlib import Path

from harness.commands.console import say
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
    viewer = shutil.which("rerun")
    if has_display() and viewer:
        # Loopback only: the viewer's server must not listen on every interface.
        return subprocess.call([viewer, "--bind", "127.0.0.1", str(path)])
    say(f"no display here; to look at {path}:")
    say(f"  - on a machine with a display: pip install rerun-sdk==0.41.* && rerun {path.name}")
    say(f"  - or serve it to a browser:     rerun --bind 127.0.0.1 --web-viewer {path}")
    say("  - or drag the file onto https://rerun.io/viewer (version 0.41)")
    return 0
