"""Building a run's report: ``build_report(run_dir)`` writes

- ``summary.csv``: one row per sweep point and task (task, robot, arm, object, point, the
  ``param.*`` values): n, successes, rate, 95% Wilson interval, the valid rate and its interval,
  ``fallback`` (episodes whose candidates came from the reference fallback), ``errors`` (rows
  left out of every rate), ``fail.<reason>`` counts for the whole failure taxonomy, and medians
  of the candidate counts and wall time;
- ``best.csv``: per robot, arm and object, the point with the highest Wilson lower bound over
  the swept settings, so a lucky 2/2 does not beat a solid 18/20;
- ``plots/``: success per robot, arm and object over the swept settings, failure reasons per
  point, the candidate funnel;
- ``plots/placement.png``: outcome vs the object's placement per robot arm (reach);
- ``videos/`` (with ``videos=True``): one episode per outcome class and one success and one
  failure per robot arm, replayed (kept on the page by later reports without ``videos``);
- ``report.md`` (tables, links, plot links) and ``report.html`` (self-contained and interactive:
  plotly heatmaps, sortable tables, embedded plots and videos; ``harness.report.page``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from harness.files import refuse_planted_links, write_atomic
from harness.report import failure_groups
from harness.report.answer import FirstScreen, answer_table, sweep_answers
from harness.report.episode_sections import (
    errors_table,
    examples_table,
    failure_groups_table,
    recording_links,
)
from harness.report.findings import findings
from harness.report.frames import column
from harness.report.heatmaps import success_heatmaps
from harness.report.labels import varying_params
from harness.report.objective import (
    RECORD_NAME,
    effective_objective,
    record_objective,
    resolve_objective,
)
from harness.report.page import render_page
from harness.report.placement import plot_placement
from harness.report.plots import plot_failures, plot_funnel, plot_success
from harness.report.render import render_markdown
from harness.report.sections import Table, funnel_tables, report_tables
from harness.report.sensitivity import sensitivity_tables
from harness.report.tables import (
    best_settings,
    error_rows,
    funnel,
    load_episodes,
    rated,
    setting_params,
    summarize,
)
from harness.report.tune_link import (
    RUN_PARTS,
    check_table,
    decisions_table,
    objects_tables,
    own_tune,
    related_tunes,
    relative,
    tune_answers,
)
from harness.report.videos import Clip, load_clips, render_clips
from harness.runs.store import JSONL_NAME, ResultStore
from harness.writes import output_dir

SUMMARY_NAME = "summary.csv"


BEST_NAME = "best.csv"
# Everything ``build_report`` writes (with ``export``, the episode tables too; with ``videos``,
# replays that log to MuJoCo's log), and the run's recording.
REPORT_OUTPUTS = (
    "MUJOCO_LOG.TXT",
    "recording.rrd",
    SUMMARY_NAME,
    BEST_NAME,
    RECORD_NAME,
    "plots",
    "videos",
    "report.md",
    "report.html",
    "episodes.csv",
    "episodes.parquet",
    ".episodes.csv.tmp",
    ".episodes.parquet.tmp",
)


@dataclass(frozen=True)
class ReportPaths:
    """Everything ``build_report`` wrote."""

    run_dir: Path
    summary_csv: Path
    best_csv: Path
    report_md: Path
    report_html: Path
    plots: dict[str, Path] = field(default_factory=dict)
    videos: list[Clip] = field(default_factory=list)
    objective: str = "valid"  # the objective the report ranked by (after any fallback)


def group_failures(frame: pd.DataFrame) -> pd.DataFrame:
    """Failure messages of the rated episodes (``error`` rows have their own table) grouped per
    robot, arm and reason by their normalised pattern (``harness.report.failure_groups``)."""
    return failure_groups.group_failures(rated(frame))


def episode_tables(run_dir: Path, frame: pd.DataFrame, summary: pd.DataFrame) -> list[Table]:
    """Error rows, grouped failure messages and example episodes, ids linked to recordings."""
    links = recording_links(run_dir, frame)
    params = setting_params(summary) or varying_params(summary)
    tables: list[Table] = []
    errors = error_rows(frame)
    if len(errors):
        tables.append(errors_table(errors, params, links))
    groups = group_failures(frame)
    if len(groups):
        tables.append(failure_groups_table(groups, links))
    tables.append(examples_table(frame, params, links))
    return tables


def first_screen(
    run_dir: Path, frame: pd.DataFrame, summary: pd.DataFrame, objective: str
) -> FirstScreen:
    """The answer tables (a tune's decisions first, when ``run_dir`` is its screening or race),
    the objective line and links to tunes of the same tasks."""
    params = setting_params(summary) or varying_params(summary)
    answers = sweep_answers(summary, objective, params)
    tune = own_tune(run_dir)
    tables: list[Table] = []
    links: list[tuple[str, str]] = []
    if tune is not None:
        tables.append(
            answer_table(
                tune_answers(tune), tune.objective,
                "Tune decisions: which setting, how sure, why the rest fail",
            )
        )  # fmt: skip
        checked = check_table(tune)  # the decisions on fresh seeds, when checked
        tables.extend([checked] if checked is not None else [])
        tables.extend(objects_tables(tune))  # a template tune's objects
        tables.append(
            answer_table(answers, objective, "Screening candidates (chosen on these seeds)")
        )
        links.append(("tuned.md (the keys to merge)", relative(tune.markdown(), run_dir)))
    else:
        tables.append(answer_table(answers, objective))
        tasks = {str(t) for t in column(frame, "task").dropna()} if "task" in frame else set()
        for found in related_tunes(run_dir, tasks):
            page = found.page() if found.page().is_file() else found.markdown()
            links.append((f"{found.path.name} (decided on fresh seeds)", relative(page, run_dir)))
    note = ""
    parent = Path(run_dir).resolve().parent
    if (
        tune is None
        and Path(run_dir).resolve().name in RUN_PARTS
        and (parent / "tune.json").is_file()
    ):
        note = (
            "this is a tune's screening: its race on fresh seeds has not decided yet (running, "
            "or interrupted: run the same harness tune command to continue); the candidates "
            "below were chosen on these seeds, not tested"
        )
    return FirstScreen(tables, objective, tune.path if tune else None, links, note)


def build_report(
    run_dir: str | Path,
    export: bool = False,
    objective: str | None = None,
    videos: bool = False,
) -> ReportPaths:
    """Rebuild summary.csv, best.csv, plots/, report.md and report.html of ``run_dir``.

    With ``export`` the store is also re-exported to episodes.csv / episodes.parquet (only when
    it has an ``episodes.jsonl``; a hand-made episodes.csv is never overwritten). ``objective``
    (``valid`` or ``reference``; None: the run's recorded one, else ``valid``) ranks the
    settings, colours the heatmaps and answers the first screen; it is recorded in
    ``report.json``. ``videos`` replays one success and one failure per robot arm and embeds
    their MP4s (a few seconds of work per clip).
    """
    run_dir = Path(run_dir)
    refuse_planted_links(run_dir, REPORT_OUTPUTS)  # a write must never follow a planted link
    frame = load_episodes(run_dir)
    if export and (run_dir / JSONL_NAME).is_file():
        ResultStore(run_dir).export()
    summary = summarize(frame)
    asked = resolve_objective(run_dir, objective)
    used = effective_objective(summary, asked)
    best = best_settings(summary, used)
    summary_csv = run_dir / SUMMARY_NAME
    best_csv = run_dir / BEST_NAME
    write_atomic(
        summary_csv, summary.to_csv(index=False), root=run_dir
    )  # whole or absent, never half
    write_atomic(best_csv, best.to_csv(index=False), root=run_dir)
    record_objective(run_dir, asked, used)

    plots_dir = run_dir / "plots"
    output_dir(plots_dir, run_dir)
    plots = {
        "success": plot_success(summary, plots_dir / "success.png", used),
        "failures": plot_failures(summary, plots_dir / "failures.png", used),
        "funnel": plot_funnel(funnel(frame), plots_dir / "funnel.png"),
    }
    placement = plot_placement(frame, plots_dir / "placement.png")
    if placement is not None:
        plots["placement"] = placement
    tables = [
        *report_tables(frame, summary, best),
        *sensitivity_tables(summary),
        *episode_tables(run_dir, frame, summary),
        *funnel_tables(funnel(frame)),
    ]
    screen = first_screen(run_dir, frame, summary, used)
    tune = own_tune(run_dir)
    if tune is not None:  # every column of the tune's decisions, first of the folded tables
        tables.insert(0, decisions_table(tune))
    if used != asked:
        note = f"no episode was judged for validity: ranked by the {used} rate"
        screen = FirstScreen(screen.tables, used, screen.tune_path, screen.tune_links, note)
    found = findings(frame, best)
    # Without rendering, the videos of an earlier report stay on the page (videos/clips.json).
    clips = render_clips(run_dir, frame) if videos else load_clips(run_dir)
    report_md = run_dir / "report.md"
    report_html = run_dir / "report.html"
    write_atomic(
        report_md,
        render_markdown(run_dir, frame, tables, plots, clips, screen, found),
        root=run_dir,
    )
    links = recording_links(run_dir, frame)
    page = render_page(
        run_dir, frame, tables, plots, success_heatmaps(summary, used), clips, links,
        found, screen,
    )  # fmt: skip
    write_atomic(report_html, page, root=run_dir)
    return ReportPaths(run_dir, summary_csv, best_csv, report_md, report_html, plots, clips, used)
