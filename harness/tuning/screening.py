"""A finished screening read back: its sweep (both passes), tasks and rated settings."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from harness.config import SweepConfig, TaskConfig
from harness.report.tables import load_episodes
from harness.runs.expansion import load_sweep_tasks
from harness.runs.rundir import RunDir
from harness.tuning.analysis import merge_passes, settings_frame
from harness.tuning.grid import (
    merged_sweep,
)

SCREEN_DIR, REFINE_DIR = "screen", "refine"


def load_screening(
    out: Path, objective: str
) -> tuple[SweepConfig, dict[str, TaskConfig], pd.DataFrame]:
    """The screening's sweep (both passes' settings), tasks and settings frame."""
    screen = RunDir(out / SCREEN_DIR)
    sweep = screen.load_sweep()
    tasks = {t.name: t for t in load_sweep_tasks(sweep, screen.sweep_yaml)}
    settings = settings_frame(load_episodes(screen.path), sweep, objective)
    refine = RunDir(out / REFINE_DIR)
    if refine.sweep_yaml.is_file():  # the fine pass after the coarse one: both screen
        second = refine.load_sweep()
        later = settings_frame(load_episodes(refine.path), second, objective)
        settings = merge_passes(settings, later)
        sweep = merged_sweep(sweep, second)
    return sweep, tasks, settings
