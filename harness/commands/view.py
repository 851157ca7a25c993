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


DISPLAY_PROBE_TIMEOUT_S = 2.0  # a display server answers a connect at once; chosen


def dead_display() -> str | None:
    """Which display variable names a server that does not answer (``DISPLAY=:99`` with no X
    server made the viewer print a multi-line winit error), else None. A Wayland socket is
    ``$XDG_RUNTIME_DIR/$WAYLAND_DISPLAY``; an X display ``:N`` is the socket
    ``/tmp/.X11-unix/XN`` (or the abstract one Linux also offers), ``HOST:N`` TCP port 6000+N."""
    import socket

    wayland = os.environ.get("WAYLAND_DISPLAY")
    if wayland:
        runtime = os.environ.get("XDG_RUNTIME_DIR", "")
        socket_path = wayland if wayland.startswith("/") else os.path.join(runtime, wayland)
        if _connects(socket.AF_UNIX, socket_path):
            return None
    display = os.environ.get("DISPLAY")
    if not display:
        return f"WAYLAND_DISPLAY={wayland}" if wayland else None
    host, _, rest = display.rpartition(":")
    number = rest.split(".")[0]
    if not number.isdigit():
        return f"DISPLAY={display}"
    if host in ("", "unix"):
        for address in (f"/tmp/.X11-unix/X{number}", f"\0/tmp/.X11-unix/X{number}"):
            if _connects(socket.AF_UNIX, address):
                return None
        return f"DISPLAY={display}"
    if _connects(socket.AF_INET, (host, 6000 + int(number))):
        return None
    return f"DISPLAY={display}"


def _connects(family: int, address: object) -> bool:
    import socket

    try:
        with socket.socket(family, socket.SOCK_STREAM) as probe:
            probe.settimeout(DISPLAY_PROBE_TIMEOUT_S)
            probe.connect(address)  # type: ignore[arg-type]
        return True
    except (OSError, ValueError):
        return False


def _web_hint(path: Path) -> str:
    """The browser alternative, as a command that runs as printed (``rerun_viewer``)."""
    native = rerun_viewer() or f"{sys.executable} -m rerun"
    return f"serve it to a browser: {native} --bind 127.0.0.1 --web-viewer {path}"


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
        dead = dead_display() if sys.platform.startswith("linux") else None
        if dead is not None:
            raise HarnessError(f"{dead}: no display server answers there; {_web_hint(path)}")
        return _open_viewer(viewer, path)
    for line in open_instructions(path, viewer):
        say(line)
    return 0


def _open_viewer(viewer: str, path: Path) -> int:
    """Run the Rerun viewer (on loopback only: its server must not listen on every
    interface). Its log goes to a temp file; if it fails, its last line and the web-viewer
    hint are one error line instead of its multi-line log."""
    import tempfile

    with tempfile.TemporaryFile(mode="w+", encoding="utf-8", errors="replace") as log:
        code = subprocess.call([viewer, "--bind", "127.0.0.1", str(path)], stderr=log)
        if code == 0:
            return 0
        log.seek(0)
        lines = [line.strip() for line in log.read().splitlines() if line.strip()]
    last = lines[-1][:200] if lines else f"exit status {code}"
    raise HarnessError(f"{path}: the Rerun viewer failed ({last}); {_web_hint(path)}")


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
