"""``tune``: run the tune grid as one sweep, then analyse it into ``<run dir>/tune/``.

The sweep is an ordinary run directory (``sweep.yaml``, the episode store, the usual report), so
it can be resumed, replayed and compared like any other; :func:`analyse` only reads it.
Written into ``<run dir>/tune/``: ``tuned.yaml``, ``tuned.md``, ``success_map.csv`` (every
setting per robot, arm and object, and pooled per robot and arm), ``choices.csv`` and one
heatmap PNG per robot, arm and object under ``heatmaps/``.
"""

from __future__ import annotations

import json
import tempfile
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
import yaml

from harness.config import TaskConfig
from harness.report.finish import finish_run
from harness.report.frames import frame_of
from harness.report.tables import load_episodes
from harness.runs.expansion import load_sweep_tasks
from harness.runs.rundir import RunDir
from harness.runs.sweep import run_sweep
from harness.tuning.analysis import POOLED, choices, settings_frame, success_map
from harness.tuning.blocks import tuned_markdown, tuned_yaml
from harness.tuning.grid import current_setting, load_inputs, tune_sweep
from harness.tuning.heatmaps import write_heatmaps

DEFAULT_EPISODES = 20
TUNE_DIR = "tune"


@dataclass(frozen=True)
class TuneResult:
    """Where a tune wrote its outputs, and the choices it made (``analysis.choices``)."""

    run_dir: Path
    interrupted: bool
    tuned_yaml: Path
    tuned_md: Path
    heatmaps: list[Path]
    choices: pd.DataFrame
    yaml_text: str


def tune(
    paths: list[Path],
    *,
    episodes: int | None = None,
    step: int = 5,
    bands: int = 3,
    objective: str = "reference",
    out: Path | None = None,
    workers: int | None = None,
    seed: int | None = None,
    backend: str = "process",
    progress: bool = False,
    engine: str = "mujoco",
) -> TuneResult:
    """Run the grid of ``harness.tuning.grid`` over the tasks of ``paths`` and analyse it."""
    tasks, axes, sweep_seed = load_inputs(paths)
    sweep = tune_sweep(
        tasks,
        axes,
        step=step,
        bands=bands,
        episodes=episodes or DEFAULT_EPISODES,
        seed=seed if seed is not None else (sweep_seed or 0),
    )
    with tempfile.TemporaryDirectory(prefix="harness-tune-") as folder:
        path = Path(folder) / "tune.yaml"
        path.write_text(yaml.safe_dump(sweep.model_dump(mode="json"), sort_keys=False), "utf-8")
        outcome = run_sweep(
            path,
            out=out or RunDir.default_path(sweep.name),
            workers=workers,
            backend=backend,
            progress=progress,
            engine=engine,
            max_points=None,  # the tune grid is generated and bounded by --step / --bands
        )
    finish_run(outcome.run_dir)
    if outcome.stats.interrupted:
        return TuneResult(outcome.run_dir, True, Path(), Path(), [], pd.DataFrame(), "")
    return analyse(outcome.run_dir, objective)


def _current_pairs(tasks: list[TaskConfig]) -> dict[tuple[str, str], tuple[str, str]]:
    """(robot, arm) -> the current (approach, facing) as their param-column JSON (first task)."""
    pairs: dict[tuple[str, str], tuple[str, str]] = {}
    for task in tasks:
        setting = current_setting(task)
        pairs.setdefault(
            (task.robot, task.arm),
            (
                json.dumps(setting["pick.approach_filter"]),
                json.dumps(setting["pick.facing_filter"]),
            ),
        )
    return pairs


def analyse(run_dir: Path, objective: str = "reference") -> TuneResult:
    """Success maps, best settings, tests, heatmaps and tuned blocks of a tune run directory."""
    run = RunDir(run_dir)
    sweep = run.load_sweep()
    tasks = load_sweep_tasks(sweep, run.sweep_yaml)
    settings = settings_frame(load_episodes(run_dir), objective)
    chosen = choices(settings, _current_pairs(tasks))
    per_object = success_map(settings, ["robot", "arm", "object"])
    pooled = success_map(settings, ["robot", "arm"]).assign(object=POOLED)
    out = run_dir / TUNE_DIR
    out.mkdir(parents=True, exist_ok=True)
    pd.concat([per_object, pooled]).to_csv(out / "success_map.csv", index=False)
    chosen.to_csv(out / "choices.csv", index=False)
    per_object_choices = frame_of(chosen[chosen["object"] != POOLED])
    heatmaps = write_heatmaps(per_object, per_object_choices, out / "heatmaps", objective)
    images = {
        (str(r), str(a), str(o)): p
        for (r, a, o), p in zip(
            frame_of(per_object_choices[["robot", "arm", "object"]]).itertuples(index=False),
            heatmaps,
            strict=True,
        )
    }
    header = [
        f"harness tune run {run_dir}: {sweep.episodes_per_point} episodes per setting "
        f"(sweep seed {sweep.seed}), objective {objective}, 95% Wilson intervals.",
        "Pasted into a task file, each robot and arm's pick block replaces its pick block.",
    ]
    by_arm = {(task.robot, task.arm): task for task in reversed(tasks)}
    text = tuned_yaml(chosen, by_arm, header, objective)
    tuned_path = out / "tuned.yaml"
    tuned_path.write_text(text, encoding="utf-8")
    md_path = out / "tuned.md"
    md_path.write_text(tuned_markdown(chosen, text, header, images), encoding="utf-8")
    return TuneResult(run_dir, False, tuned_path, md_path, heatmaps, chosen, text)
