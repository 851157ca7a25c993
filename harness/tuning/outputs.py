"""The tune's written outputs: ``tuned.yaml``, ``tuned.md`` (with the objects' pictures), the
header lines, and ``--write``'s copies."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from harness.config import TaskConfig
from harness.files import safe_file_name
from harness.report.frames import series_rows
from harness.tuning.blocks import filter_keys, task_decisions, tuned_markdown, tuned_yaml
from harness.tuning.decide import NO_SETTING_HELPS, UNDECIDED
from harness.tuning.exceptions import (
    OVERRIDE,
    objects_markdown,
)
from harness.tuning.object_plot import object_plot
from harness.tuning.options import (
    TuneOptions,
)
from harness.tuning.race import RaceLog
from harness.tuning.write import write_copy
from harness.writes import write_file

SCREEN_DIR, TUNE_DIR = "screen", "tune"


def write_tuned(
    out: Path,
    decisions: pd.DataFrame,
    tasks: dict[str, TaskConfig],
    header: list[str],
    images: dict[tuple[str, str], Path],
    options: TuneOptions,
    objects: pd.DataFrame,
) -> str:
    """Write ``tuned.yaml`` (the keys to merge) and ``tuned.md`` (with the page's link); return
    the YAML text."""
    folder = out / TUNE_DIR
    text = tuned_yaml(
        decisions, tasks, header, options.sources, options.groups, options.pick_paths, objects
    )
    write_file(folder / "tuned.yaml", text, root=out)
    link = f"../{SCREEN_DIR}/report.html"
    page = f"\nPage (decisions first, then the screening): [{link}]({link})\n"
    pictures = {}
    for group in dict.fromkeys(objects["group"]) if len(objects) else []:
        title = f"template group {group}: every object's {options.objective} rate"
        pictures[str(group)] = object_plot(
            objects, str(group), title, folder / safe_file_name(f"objects_{group}", ".png")
        )
    body = tuned_markdown(decisions, text, header, images)
    body += "\n".join(objects_markdown(objects, pictures)) + "\n"
    write_file(folder / "tuned.md", body + page, root=out)
    return text


def header_lines(out: Path, seed: int, options: TuneOptions, log: RaceLog) -> list[str]:
    return [
        f"harness tune {out}: objective {options.objective}; screening {options.screen_seeds} "
        f"seeds (sweep seed {seed}); race of the current + {options.top} best on fresh seeds "
        f"(sweep seed {seed + 100_000}), per unit a group-sequential plan "
        + (
            f"of {options.max_seeds} seeds"
            if options.max_seeds
            else f"sized for 80% power at a +{options.target_gain:.0%} gain"
        )
        + f" in looks of {options.block} or more; exact one-sided McNemar at Lan-DeMets "
        f"Pocock-type levels (one-sided alpha {options.alpha}), Holm over the challengers"
        + (
            "; the validity phase is not run under reference semantics (nothing this objective"
            " reads needs it: the rows' validity columns are empty, as with validity: off)."
            if options.objective == "reference"
            else "."
        ),
        f"race: {log.rounds} rounds, {log.episodes} episodes, {log.seconds:.0f} episode-seconds"
        + ("; budget spent" if log.budget_spent else "")
        + ("; interrupted (run the tune again with the same --out)" if log.interrupted else "")
        + ("; race rows missing (run the tune to continue the race)" if log.missing else ""),
    ]


def write_copies(
    decisions: pd.DataFrame,
    tasks: dict[str, TaskConfig],
    options: TuneOptions,
    folder: Path,
    objects: pd.DataFrame,
) -> list[Path]:
    """Per task with a file: the merged copy and its diff under ``folder``. A task whose race
    decided nothing (undecided: cut short, no look, rows missing) or found no setting that
    helps gets no copy: there is nothing to merge. A template group's files each get the
    template, or their confirmed override."""
    written: list[Path] = []
    settings: dict[str, tuple[str, str]] = {}
    for name, decided, _ in task_decisions(decisions):
        if decided["verdict"] in (UNDECIDED, NO_SETTING_HELPS):
            continue
        for member in options.groups.get(name, [name]):
            settings[member] = decided["setting"]
    for row in series_rows(objects) if len(objects) else []:
        if row["exception"] == OVERRIDE and str(row["task"]) in settings:
            settings[str(row["task"])] = (
                str(row["own_best_approach"]),
                str(row["own_best_facing"]),
            )
    for name, setting in settings.items():
        source = options.sources.get(name)
        if source is None or not Path(source).is_file():
            continue  # an inline task: no task file to copy
        keys = filter_keys(tasks[name], setting)
        written.extend(write_copy(Path(source), keys, folder, options.pick_paths.get(name)))
    return written
