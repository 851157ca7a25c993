"""Where MuJoCo writes its own log (``MUJOCO_LOG.TXT``): the run directory, never the cwd.

MuJoCo appends warnings and errors to ``MUJOCO_LOG.TXT`` in the current directory by default,
so a sweep started from a source checkout would leave the file there. ``log_mujoco_to`` points
the process-wide log at a run directory (no chdir: workers share the process with other code).
"""

from __future__ import annotations

from pathlib import Path

import mujoco

from harness.files import refuse_planted_links

LOG_NAME = "MUJOCO_LOG.TXT"


def log_mujoco_to(run_dir: Path) -> Path:
    """Send this process's MuJoCo log to ``run_dir/MUJOCO_LOG.TXT``; returns that path."""
    path = Path(run_dir).resolve() / LOG_NAME
    path.parent.mkdir(parents=True, exist_ok=True)  # MuJoCo does not create folders
    refuse_planted_links(path.parent, [LOG_NAME])  # MuJoCo would append to a link's target
    config = mujoco.MjLogConfig.get()
    if config.logfile != str(path):
        config.logfile = str(path)
        config.set()
    return path
