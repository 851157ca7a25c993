"""``harness replay``: a stored row is reproduced exactly from the run directory alone, and the
episode is filmed offscreen into a playable MP4 (issue 14)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from harness.episode import run_episode
from harness.runs.replay import find_episode, row_differences
from harness.viz.headline import headline
from harness.viz.video import HOLD_S, frame_indices

ROOT = Path(__file__).resolve().parents[1]


def cli(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "harness.cli", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        check=False,
        timeout=600,
        env={
            **os.environ,
            "PYTHONPATH": str(ROOT),
            "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"),
        },
    )


def test_row_differences_ignore_machine_columns_and_catch_episode_ones() -> None:
    stored = {"success": True, "wall_time_s": 1.0, "lift_height_m": 0.05, "slip_m": float("nan")}
    same = {"success": True, "wall_time_s": 9.0, "lift_height_m": 0.05, "slip_m": float("nan")}
    assert row_differences(stored, same) == []
    moved = {**same, "lift_height_m": 0.051}
    assert row_differences(stored, moved) == ["lift_height_m: 0.05 -> 0.051"]


@pytest.mark.slow
def test_replay_reproduces_a_stored_row_and_writes_a_playable_mp4(tmp_path: Path) -> None:
    imageio = pytest.importorskip("imageio.v3")
    run_dir = tmp_path / "run"
    task = str(ROOT / "tasks" / "pick" / "fr3.yaml")
    made = cli("run", task, "--episodes", "2", "--seed", "4", "--record", "none",
               "--out", str(run_dir), cwd=tmp_path)  # fmt: skip
    assert made.returncode == 0, made.stderr
    rows = pd.read_csv(run_dir / "episodes.csv")
    executed = rows[rows["sim_steps"] > 0]
    assert len(executed), "no executed episode to film"
    episode_id = str(executed.iloc[0]["episode_id"])
    video = tmp_path / "videos" / "new" / "episode.mp4"  # replay makes the missing folders
    replay = cli("replay", str(run_dir), episode_id, "--video", str(video), cwd=tmp_path)
    assert replay.returncode == 0, replay.stdout + replay.stderr
    assert "row reproduced exactly" in replay.stdout
    frames = imageio.imread(video)
    assert frames.shape[1:] == (480, 640, 3)
    # One frame per 1/30 s of the episode's trace (execution and validity phase), plus the
    # HOLD_S the video rests on the frame that shows the outcome's cause.
    spec, _ = find_episode(run_dir, episode_id)
    trace = run_episode(spec).trace
    assert trace is not None
    executed_s = float(executed.iloc[0]["sim_time_s"])
    hold = round(HOLD_S * 30)
    assert len(frames) - hold == len(frame_indices(trace.time)) > 30 * executed_s - 2
    assert frames.std() > 10  # a picture, not a blank frame
    poster = imageio.imread(video.with_suffix(".png"))
    assert poster.shape == (480, 640, 3) and poster.std() > 10
    # The replay prints both verdicts: the stored row's headline.
    assert headline(executed.iloc[0].to_dict()) in replay.stdout
    assert "VALID" in headline(executed.iloc[0].to_dict())


def test_replay_of_an_unknown_episode_is_one_line(tmp_path: Path) -> None:
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    (run_dir / "episodes.jsonl").write_text("", encoding="utf-8")
    video = tmp_path / "out" / "nope.mp4"
    result = cli("replay", str(run_dir), "nope", "--video", str(video), cwd=tmp_path)
    assert result.returncode == 2 and "no episode 'nope' in this run" in result.stderr
    assert not video.parent.exists()  # no folder made for an episode that is not there
