"""Short videos for the report: one success and one failure per robot arm, rendered at report
time by replaying their stored rows (episodes are deterministic in task, point and seed) with
the offscreen renderer of ``harness replay --video`` (``harness.viz.video``), small and at a low
frame rate so the clips stay a few hundred KB and a few seconds of work each.

The MP4s go to ``RUN_DIR/videos/``; ``report.html`` embeds them. A replay whose verdict differs
from its stored row says so in its caption (never silently shown as the stored episode); a clip
that cannot be rendered (no GL, an episode that stopped before its scene) is reported, and the
report is written without it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from harness.report.frames import column, frame_of
from harness.report.tables import rated
from harness.runs.safety import safe_file_name

VIDEOS_DIR = "videos"
SWEEP_YAML = "sweep.yaml"  # harness.runs.rundir.SWEEP_YAML (rundir imports the report)
FPS = 10
WIDTH, HEIGHT = 320, 240
MAX_CLIPS = 16
CHECKED = ("success", "failure_reason", "chosen_index")  # what a caption must be true about


@dataclass(frozen=True)
class Clip:
    """One rendered (or failed) video of a stored episode."""

    robot: str
    arm: str
    object: str
    outcome: str  # "success" or the failure reason
    episode_id: str
    seed: int
    path: Path | None  # the MP4, relative to the run directory; None when rendering failed
    frames: int = 0
    note: str = ""  # why there is no video, or how the replay differed from the row


def chosen_episodes(frame: pd.DataFrame, max_clips: int = MAX_CLIPS) -> pd.DataFrame:
    """Per robot and arm, the first success and the first failure (run order), at most
    ``max_clips`` rows; ``error`` rows are never chosen."""
    frame = rated(frame)
    order = [c for c in ("point_id", "episode_index") if c in frame]
    frame = frame_of(frame.sort_values(order, kind="stable")) if order else frame
    picked = []
    for _, group in frame.groupby(["robot", "arm"], sort=True):
        success = column(group, "success").astype(bool)
        for mask in (success, ~success):
            if mask.any():
                picked.append(frame_of(group.loc[mask]).head(1))
    if not picked:
        return frame.head(0)
    return frame_of(pd.concat(picked).head(max_clips))


def _specs(run_dir: Path, wanted: set[str]) -> dict[str, Any]:
    from harness.config import load_sweep
    from harness.runs.expansion import expand, load_sweep_tasks

    sweep_yaml = run_dir / SWEEP_YAML
    sweep = load_sweep(sweep_yaml)
    specs = expand(sweep, sweep_yaml, load_sweep_tasks(sweep, sweep_yaml))
    return {spec.resolved_id: spec for spec in specs if spec.resolved_id in wanted}


def _differences(stored: Any, replayed: dict[str, Any]) -> str:
    changed = [
        f"{name} {stored[name]!r} -> {replayed.get(name)!r}"
        for name in CHECKED
        if name in stored.index
        and str(stored[name]) != str(replayed.get(name))
        and not (pd.isna(stored[name]) and replayed.get(name) in (None, ""))
    ]
    return "replay differs from the stored row: " + "; ".join(changed) if changed else ""


def render_clips(run_dir: Path, frame: pd.DataFrame, max_clips: int = MAX_CLIPS) -> list[Clip]:
    """Replay and film the chosen episodes of ``run_dir`` into ``run_dir/videos/``."""
    from harness.viz.render import use_offscreen_gl

    use_offscreen_gl()  # before mujoco is first imported
    chosen = chosen_episodes(frame, max_clips)
    if chosen.empty:
        return []
    try:
        specs = _specs(run_dir, set(chosen["episode_id"].astype(str)))
    except Exception as exc:  # a run directory without a usable sweep.yaml: no videos
        return [_clip(row, None, note=f"not replayable: {exc}") for _, row in chosen.iterrows()]
    if (run_dir / VIDEOS_DIR).is_symlink():  # never write through a planted symlink
        return [_clip(row, None, note="videos/ is a symlink") for _, row in chosen.iterrows()]
    (run_dir / VIDEOS_DIR).mkdir(exist_ok=True)
    scenes: dict[Any, Any] = {}  # one scene per robot and object, as a sweep worker keeps them
    return [
        _film(run_dir, row, specs.get(str(row["episode_id"])), scenes)
        for _, row in chosen.iterrows()
    ]


def _clip(row: Any, path: Path | None, frames: int = 0, note: str = "") -> Clip:
    outcome = "success" if bool(row["success"]) else str(row["failure_reason"])
    return Clip(
        str(row["robot"]),
        str(row["arm"]),
        str(row["object"]),
        outcome,
        str(row["episode_id"]),
        int(row["seed"]),
        path,
        frames,
        note,
    )


def _film(run_dir: Path, row: Any, spec: Any, scenes: dict[Any, Any]) -> Clip:
    if spec is None:
        return _clip(row, None, note="its sweep.yaml no longer expands to this episode")
    from harness.episode import run_episode
    from harness.viz.video import write_episode_video

    relative = Path(VIDEOS_DIR) / safe_file_name(str(row["episode_id"]), ".mp4")
    try:
        result = run_episode(spec, scenes)
        frames = write_episode_video(result, run_dir / relative, FPS, WIDTH, HEIGHT)
    except Exception as exc:  # no GL context, no scene: the report goes on without this clip
        return _clip(row, None, note=f"not rendered: {type(exc).__name__}: {exc}")
    return _clip(row, relative, frames, _differences(row, result.row))
