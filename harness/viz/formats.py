"""The file types each output flag writes, checked before any work is done.

``replay --video clip`` or ``objects show --render img`` ran the whole episode or render and then
failed in imageio / PIL / matplotlib with a ``ValueError`` traceback (``robots show --render``
caught it only after rendering). ``check_suffix`` refuses an unknown extension up front with one
line naming the flag and the extensions that work; every output flag of the commands uses it.
"""

from __future__ import annotations

from pathlib import Path

from harness.errors import HarnessError

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg")  # offscreen renders, written by PIL
PLOT_SUFFIXES = (".png", ".pdf", ".svg")  # matplotlib figures
VIDEO_SUFFIXES = (".mp4",)  # imageio-ffmpeg (H.264)
RECORDING_SUFFIXES = (".rrd",)  # Rerun recordings


def check_suffix(path: str | Path, allowed: tuple[str, ...], flag: str) -> Path:
    """``Path(path)`` if its extension (any case) is one of ``allowed``; else ``HarnessError``:
    ``--video clip: unknown extension '(none)'; use .mp4``."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in allowed:
        raise HarnessError(
            f"{flag} {path}: unknown extension {suffix or '(none)'!r}; use {' or '.join(allowed)}"
        )
    return path
