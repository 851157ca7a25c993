"""Short videos for the report: one episode of each outcome class the run produced (a valid
success, a reference success that is not valid per validity reason, a failure per failure
reason) plus one success and one failure per robot arm, rendered at report time by replaying
their stored rows (episodes are deterministic in task, point and seed) with the offscreen
renderer of ``harness replay --video`` (``harness.viz.video``: caption, cause frame, poster),
small and at a low frame rate so the clips stay a few hundred KB and a few seconds of work each.
An episode filmed without a recording of its own also gets one (``episodes/<id>.rrd``), so every
outcome class has a recording and a video.

The MP4s and posters go to ``RUN_DIR/videos/`` with ``clips.json`` describing them, which a
later ``harness report --no-videos`` reads to keep them on the page. A replay whose verdict
differs from its stored row says so in its caption (never silently shown as the stored
episode); a clip that cannot be rendered (no GL, an episode that stopped before its scene) is
reported, and the report is written without it.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from harness.files import write_atomic
from harness.reading import read_json
from harness.report.frames import column, frame_of, series_rows
from harness.report.tables import rated
from harness.runs.safety import safe_file_name
from harness.writes import output_dir

VIDEOS_DIR = "videos"
SWEEP_YAML = "sweep.yaml"  # harness.runs.rundir.SWEEP_YAML (rundir imports the report)
# Readable captions at a bounded cost: 640x480 (the caption band's text is 16 px) at 20 fps,
# which halves the frames of harness replay --video's 30 fps; chosen, no public source.
FPS = 20
WIDTH, HEIGHT = 640, 480
MAX_CLIPS = 24
MANIFEST = "clips.json"
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
    outcome_class: str = ""  # harness.viz.headline.outcome_class
    headline: str = ""  # both verdicts (harness.viz.headline.headline)
    kind: str = ""  # valid | invalid | failed
    poster: Path | None = None  # the cause frame (PNG), relative to the run directory
    recording: str | None = None  # the episode's .rrd, relative to the run directory

    def as_json(self) -> dict[str, Any]:
        data = asdict(self)
        for key in ("path", "poster"):
            data[key] = None if data[key] is None else str(data[key])
        return data


def save_manifest(run_dir: Path, clips: list[Clip]) -> None:
    """``videos/clips.json``: what a later report without rendering shows."""
    text = json.dumps([clip.as_json() for clip in clips], indent=1)
    write_atomic(run_dir / VIDEOS_DIR / MANIFEST, text, root=run_dir)


def load_clips(run_dir: Path) -> list[Clip]:
    """The clips of an earlier report whose files are still there (``--no-videos`` keeps
    them); [] when there is no readable manifest."""
    path = run_dir / VIDEOS_DIR / MANIFEST
    try:  # the read rule: a FIFO or a huge file planted here is no manifest
        entries = read_json(path, what="video manifest")
    except (OSError, ValueError):  # InputFileError is a ValueError
        return []
    clips = []
    for entry in entries if isinstance(entries, list) else []:
        try:
            video = Path(entry["path"]) if entry.get("path") else None
            poster = Path(entry["poster"]) if entry.get("poster") else None
            if video is None or not (run_dir / video).is_file():
                continue
            if poster is not None and not (run_dir / poster).is_file():
                poster = None
            clips.append(Clip(**{**entry, "path": video, "poster": poster}))
        except (KeyError, TypeError):
            continue
    return clips


def chosen_episodes(frame: pd.DataFrame, max_clips: int = MAX_CLIPS) -> pd.DataFrame:
    """The first episode (run order) of each outcome class, then per robot and arm the first
    success and the first failure not already chosen; at most ``max_clips`` rows; ``error``
    rows are never chosen."""
    from harness.viz.headline import outcome_class

    frame = rated(frame)
    order = [c for c in ("point_id", "episode_index") if c in frame]
    frame = frame_of(frame.sort_values(order, kind="stable")) if order else frame
    if frame.empty:
        return frame.head(0)
    classes = pd.Series([outcome_class(row) for row in series_rows(frame)], index=frame.index)
    picked: list[Any] = list(classes.drop_duplicates().index)
    for _, group in frame.groupby(["robot", "arm"], sort=True):
        success = column(group, "success").astype(bool)
        for mask in (success, ~success):
            if mask.any() and not set(group.index[mask]) & set(picked):
                picked.append(group.index[mask][0])
    return frame_of(frame.loc[picked[:max_clips]])


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
    from harness.runs.progress import ProgressLines
    from harness.viz.render import use_offscreen_gl

    use_offscreen_gl()  # before mujoco is first imported
    chosen = chosen_episodes(frame, max_clips)
    if chosen.empty:
        return []
    try:
        specs = _specs(run_dir, set(chosen["episode_id"].astype(str)))
    except Exception as exc:  # a run directory without a usable sweep.yaml: no videos
        return [_clip(row, None, note=f"not replayable: {exc}") for _, row in chosen.iterrows()]
    output_dir(run_dir / VIDEOS_DIR, run_dir)  # a planted videos/ link: refused, not followed
    scenes: dict[Any, Any] = {}  # one scene per robot and object, as a sweep worker keeps them
    clips: list[Clip] = []
    # A progress line every 30 s while filming takes long (``harness.runs.progress``).
    with ProgressLines("report videos", len(chosen), unit="clips") as lines:
        for _, row in chosen.iterrows():
            clips.append(_film(run_dir, row, specs.get(str(row["episode_id"])), scenes))
            lines.advance()
    save_manifest(run_dir, clips)
    return clips


def _stored_recording(run_dir: Path, row: Any) -> str | None:
    value = row.get("recording")
    if isinstance(value, str) and value and (run_dir / value).is_file():
        return value
    return None


def _clip(
    row: Any,
    path: Path | None,
    frames: int = 0,
    note: str = "",
    recording: str | None = None,
) -> Clip:
    from harness.viz.headline import headline, outcome_class, outcome_kind

    outcome = "success" if bool(row["success"]) else str(row["failure_reason"])
    poster = path.with_suffix(".png") if path is not None else None
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
        outcome_class(row),
        headline(row),
        outcome_kind(row),
        poster,
        recording,
    )


def _film(run_dir: Path, row: Any, spec: Any, scenes: dict[Any, Any]) -> Clip:
    if spec is None:
        return _clip(row, None, note="its sweep.yaml no longer expands to this episode")
    from harness.episode import run_episode
    from harness.viz.video import write_episode_video

    relative = Path(VIDEOS_DIR) / safe_file_name(str(row["episode_id"]), ".mp4")
    recording = _stored_recording(run_dir, row)
    try:
        result = run_episode(spec, scenes)
        frames = write_episode_video(result, run_dir / relative, FPS, WIDTH, HEIGHT, run_dir)
    except Exception as exc:  # no GL context, no scene: the report goes on without this clip
        return _clip(row, None, note=f"not rendered: {type(exc).__name__}: {exc}")
    if recording is None:
        recording = _record(run_dir, row, result, spec)
    return _clip(row, relative, frames, _differences(row, result.row), recording)


def _record(run_dir: Path, row: Any, result: Any, spec: Any) -> str | None:
    """Write the filmed episode's recording when the run kept none (None if that fails)."""
    from harness.viz.recording import record_episode

    relative = Path("episodes") / safe_file_name(str(row["episode_id"]), ".rrd")
    try:
        output_dir(run_dir / "episodes", run_dir)
        record_episode(result, run_dir / relative, spec.task)
    except Exception:  # the video stands without it
        return None
    return str(relative)
