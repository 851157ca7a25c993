"""Run reports: per-point success with Wilson intervals, failure breakdown, best settings, plots.

``build_report(run_dir)`` reads the run's episodes (``harness.runs.store.ResultStore``) and writes

- ``summary.csv``: one row per sweep point and task (task, robot, arm, object, point, the
  ``param.*`` values): n, successes, rate, 95% Wilson interval, ``fail.<reason>`` counts for
  the whole failure taxonomy, and medians of the candidate counts and wall time;
- ``best.csv``: per robot, the point with the highest Wilson lower bound (pooled over the robot's
  arms and objects), so a lucky 2/2 does not beat a solid 18/20;
- ``plots/``: success over the swept axes, failure reasons per point, the candidate funnel;
- ``report.md`` (tables + plot links) and ``report.html`` (self-contained, plots embedded).

``compare_runs(run_a, run_b)`` matches points between two runs and tests each rate difference.
"""

from __future__ import annotations

import base64
import html
import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from harness.errors import HarnessError
from harness.failures import FAILURE_REASONS
from harness.markdown import markdown_table
from harness.report.stats import compare_proportions, wilson_interval
from harness.row import KEY_COLUMNS, param_columns
from harness.runs.store import JSONL_NAME, ResultStore

POINT_KEY: tuple[str, ...] = (*KEY_COLUMNS, "point")
FAIL_PREFIX = "fail."
SUMMARY_NAME = "summary.csv"
MAX_MESSAGES = 10
MESSAGE_CHARS = 200
BEST_NAME = "best.csv"


@dataclass(frozen=True)
class ReportPaths:
    """Everything ``build_report`` wrote."""

    run_dir: Path
    summary_csv: Path
    best_csv: Path
    report_md: Path
    report_html: Path
    plots: dict[str, Path] = field(default_factory=dict)


# --------------------------------------------------------------------------------------------
# Loading


def load_episodes(run_dir: str | Path) -> pd.DataFrame:
    """The run's episodes; ``HarnessError`` naming the path if the run or its rows are missing."""
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise HarnessError(f"{run_dir}: run directory not found")
    store = ResultStore(run_dir)
    if not store.exists():
        raise HarnessError(f"{run_dir}: no episodes (expected {JSONL_NAME} or episodes.csv)")
    frame = store.load()
    if frame.empty:
        raise HarnessError(f"{run_dir}: no episodes recorded yet")
    frame.attrs["skipped_lines"] = list(store.skipped_lines)
    return frame


# --------------------------------------------------------------------------------------------
# Aggregation


def _rate_columns(successes: pd.Series, n: pd.Series) -> pd.DataFrame:
    bounds = [wilson_interval(int(k), int(m)) for k, m in zip(successes, n, strict=True)]
    return pd.DataFrame(
        {
            "rate": [int(k) / int(m) if m else math.nan for k, m in zip(successes, n, strict=True)],
            "wilson_lo": [lo for lo, _ in bounds],
            "wilson_hi": [hi for _, hi in bounds],
        },
        index=successes.index,
    )


def failure_reasons_in(frame: pd.DataFrame) -> list[str]:
    """The taxonomy, plus any other reason found in failed rows (``unknown`` for blanks)."""
    failed = frame.loc[~frame["success"], "failure_reason"].replace("", "unknown")
    extra = sorted(set(failed) - set(FAILURE_REASONS))
    return [*FAILURE_REASONS, *extra]


def summarize(frame: pd.DataFrame) -> pd.DataFrame:
    """One row per (task, robot, arm, object, point): counts, rate, Wilson bounds, failures."""
    params = param_columns(frame.columns)
    reasons = failure_reasons_in(frame)
    frame = frame.assign(
        _reason=frame["failure_reason"].where(frame["failure_reason"] != "", "unknown")
    )
    rows: list[dict[str, Any]] = []
    for key, group in frame.groupby(list(POINT_KEY), sort=False, dropna=False):
        row: dict[str, Any] = dict(zip(POINT_KEY, key, strict=True))
        row["point_id"] = int(group["point_id"].min())
        for name in params:
            row[name] = group[name].iloc[0]
        row["n"] = len(group)
        row["successes"] = int(group["success"].sum())
        failed = group.loc[~group["success"], "_reason"].value_counts()
        for reason in reasons:
            row[FAIL_PREFIX + reason] = int(failed.get(reason, 0))
        row["median_n_passed_filter"] = float(group["n_passed_filter"].median())
        row["median_n_feasible"] = float(group["n_feasible"].median())
        row["median_wall_time_s"] = float(group["wall_time_s"].median())
        rows.append(row)
    summary = pd.DataFrame(rows)
    if summary.empty:
        return summary
    rates = _rate_columns(summary["successes"], summary["n"])
    fail_columns = [FAIL_PREFIX + reason for reason in reasons]
    medians = ["median_n_passed_filter", "median_n_feasible", "median_wall_time_s"]
    ordered = [
        *KEY_COLUMNS,
        "point_id",
        "point",
        *params,
        "n",
        "successes",
        *rates.columns,
        *fail_columns,
        *medians,
    ]
    summary = pd.concat([summary, rates], axis=1)[ordered]
    return summary.sort_values(["robot", "arm", "object", "task", "point_id"], kind="stable")


def pooled(summary: pd.DataFrame, by: list[str]) -> pd.DataFrame:
    """Sum n and successes of summary rows over everything but ``by``; rate and Wilson again."""
    params = param_columns(summary.columns)
    aggregations: dict[str, Any] = {"n": "sum", "successes": "sum"}
    if "point_id" not in by:
        aggregations["point_id"] = "min"
    for name in params:
        if name not in by:
            aggregations[name] = "first"
    fail_columns = [c for c in summary.columns if c.startswith(FAIL_PREFIX)]
    for name in fail_columns:
        aggregations[name] = "sum"
    out = summary.groupby(by, sort=False, dropna=False).agg(aggregations).reset_index()
    return pd.concat([out, _rate_columns(out["successes"], out["n"])], axis=1)


def best_settings(summary: pd.DataFrame) -> pd.DataFrame:
    """Per robot, the point with the highest Wilson lower bound over its arms and objects.

    Ties go to the higher rate, then the larger sample, then the earlier point.
    """
    per_point = pooled(summary, ["robot", "point"])
    per_point["points_compared"] = per_point.groupby("robot")["point"].transform("count")
    ranked = per_point.sort_values(
        ["robot", "wilson_lo", "rate", "n", "point_id"],
        ascending=[True, False, False, False, True],
        kind="stable",
    )
    best = ranked.groupby("robot", sort=True).head(1)
    params = param_columns(summary.columns)
    columns = [
        "robot",
        "point_id",
        "point",
        *params,
        "n",
        "successes",
        "rate",
        "wilson_lo",
        "wilson_hi",
        "points_compared",
    ]
    return best[columns].reset_index(drop=True)


def failure_totals(frame: pd.DataFrame) -> pd.DataFrame:
    """Failure counts per robot (rows) and reason (columns, only reasons that occur)."""
    failed = frame.loc[~frame["success"]]
    if failed.empty:
        return pd.DataFrame(index=pd.Index(sorted(frame["robot"].unique()), name="robot"))
    reasons = failed["failure_reason"].replace("", "unknown")
    table = pd.crosstab(failed["robot"], reasons)
    order = [r for r in failure_reasons_in(frame) if r in table.columns]
    return table[order]


def funnel(frame: pd.DataFrame) -> pd.DataFrame:
    """Per robot: candidate sums (total -> passed filter -> feasible -> succeeded) and the
    share of episodes reaching each stage."""
    rows = []
    for robot, group in frame.groupby("robot", sort=True):
        rows.append(
            {
                "robot": robot,
                "episodes": len(group),
                "candidates_total": int(group["n_total"].sum()),
                "candidates_passed_filter": int(group["n_passed_filter"].sum()),
                "candidates_feasible": int(group["n_feasible"].sum()),
                "candidates_succeeded": int(group["success"].sum()),
                "median_total": float(group["n_total"].median()),
                "median_passed_filter": float(group["n_passed_filter"].median()),
                "median_feasible": float(group["n_feasible"].median()),
                "episodes_filter_ok": float((group["filter_outcome"] == "ok").mean()),
                "episodes_feasible": float((group["n_feasible"] > 0).mean()),
                "episodes_success": float(group["success"].mean()),
            }
        )
    return pd.DataFrame(rows)


def error_messages(frame: pd.DataFrame) -> pd.DataFrame:
    """The most frequent (reason, message) pairs of failed episodes, with an example id."""
    failed = frame.loc[~frame["success"] & (frame["error_message"] != "")]
    if failed.empty:
        return pd.DataFrame(columns=["failure_reason", "message", "episodes", "example"])
    messages = failed.assign(message=failed["error_message"].str.slice(0, MESSAGE_CHARS))
    table = (
        messages.groupby(["failure_reason", "message"], sort=False)
        .agg(episodes=("episode_id", "size"), example=("episode_id", "first"))
        .reset_index()
        .sort_values(["episodes", "failure_reason"], ascending=[False, True], kind="stable")
    )
    return table.head(MAX_MESSAGES).reset_index(drop=True)


# --------------------------------------------------------------------------------------------
# Comparison


def compare_runs(run_a: str | Path, run_b: str | Path) -> pd.DataFrame:
    """Per-point rate difference ``rate_b - rate_a`` with its test, matched on the point key.

    The key is (task, robot, arm, object, point JSON). Points found in one run only are listed
    with ``present`` = ``a only`` / ``b only`` and no test. ``test`` is ``z`` (pooled
    two-proportion z-test) or ``fisher`` (exact, when an expected count is below 5).
    """
    summary_a = summarize(load_episodes(run_a))
    summary_b = summarize(load_episodes(run_b))
    params = list(
        dict.fromkeys(param_columns(summary_a.columns) + param_columns(summary_b.columns))
    )
    keep = [*POINT_KEY, "point_id", "n", "successes", "rate"]
    merged = pd.merge(
        summary_a[keep],
        summary_b[keep],
        on=list(POINT_KEY),
        how="outer",
        suffixes=("_a", "_b"),
        indicator=True,
    )
    params_frame = pd.concat(
        [
            summary_a[[*POINT_KEY, *_present(summary_a, params)]],
            summary_b[[*POINT_KEY, *_present(summary_b, params)]],
        ]
    )
    params_frame = params_frame.drop_duplicates(list(POINT_KEY), keep="first")
    merged = merged.merge(params_frame, on=list(POINT_KEY), how="left")
    merged["present"] = (
        merged.pop("_merge")
        .map({"both": "both", "left_only": "a only", "right_only": "b only"})
        .astype("str")
    )
    tests = []
    for _, row in merged.iterrows():
        if row["present"] != "both":
            tests.append((math.nan, math.nan, math.nan, ""))
            continue
        result = compare_proportions(
            int(row["successes_a"]), int(row["n_a"]), int(row["successes_b"]), int(row["n_b"])
        )
        tests.append((result.difference, result.z, result.p_value, result.test))
    merged["difference"] = [t[0] for t in tests]
    merged["z"] = [t[1] for t in tests]
    merged["p_value"] = [t[2] for t in tests]
    merged["test"] = pd.Series([t[3] for t in tests], index=merged.index, dtype="str")
    merged["point_id"] = merged["point_id_a"].fillna(merged["point_id_b"]).astype("int64")
    for name in ("n_a", "successes_a", "n_b", "successes_b"):
        merged[name] = merged[name].fillna(0).astype("int64")
    columns = [
        *KEY_COLUMNS,
        "point_id",
        "point",
        *[p for p in params if p in merged.columns],
        "n_a",
        "successes_a",
        "rate_a",
        "n_b",
        "successes_b",
        "rate_b",
        "difference",
        "z",
        "p_value",
        "test",
        "present",
    ]
    merged = merged.sort_values(["robot", "arm", "object", "task", "point_id"], kind="stable")
    return merged[columns].reset_index(drop=True)


def _present(frame: pd.DataFrame, names: list[str]) -> list[str]:
    return [name for name in names if name in frame.columns]


# --------------------------------------------------------------------------------------------
# Formatting helpers


def format_value(value: Any) -> str:
    """A parameter value for people: JSON lists as ``downward 140``, floats compactly."""
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value))
    if isinstance(value, (float, np.floating)):
        return "" if math.isnan(value) else f"{float(value):g}"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    text = str(value)
    if text.startswith("["):
        try:
            parsed = json.loads(text)
        except json.JSONDecodeError:
            return text
        if isinstance(parsed, list):
            return " ".join(format_value(v) for v in parsed)
    return text


def point_label(row: pd.Series | dict[str, Any], params: list[str]) -> str:
    """``filter_z_dir=downward 140, pre_grasp_offset=0.1`` (the last key part only)."""
    if not params:
        return "default"
    parts = [f"{name.split('.')[-1]}={format_value(row[name])}" for name in params]
    return ", ".join(parts)


def varying_params(frame: pd.DataFrame) -> list[str]:
    """Swept parameter columns that take more than one value in ``frame``."""
    return [name for name in param_columns(frame.columns) if frame[name].nunique(dropna=True) > 1]


def _percent(value: float) -> str:
    return (
        "" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.0%}"
    )


def _ci(lo: float, hi: float) -> str:
    return f"{lo:.2f}–{hi:.2f}"


def _top_failures(row: pd.Series, limit: int = 2) -> str:
    counts = {
        c.removeprefix(FAIL_PREFIX): int(row[c])
        for c in row.index
        if c.startswith(FAIL_PREFIX) and row[c] > 0
    }
    ranked = sorted(counts.items(), key=lambda item: (-item[1], item[0]))[:limit]
    return ", ".join(f"{reason} {count}" for reason, count in ranked)


# --------------------------------------------------------------------------------------------
# Tables for people (shared by Markdown and HTML)


@dataclass(frozen=True)
class Table:
    title: str
    header: list[str]
    rows: list[list[str]]
    note: str = ""


def report_tables(frame: pd.DataFrame, summary: pd.DataFrame, best: pd.DataFrame) -> list[Table]:
    params = varying_params(summary) or param_columns(summary.columns)
    tables: list[Table] = []

    overall = pooled(summary, ["robot", "arm", "object"])
    tables.append(
        Table(
            "Success per robot, arm and object (all points pooled)",
            ["robot", "arm", "object", "n", "successes", "rate", "95% CI"],
            [
                [
                    str(r.robot),
                    str(r.arm),
                    str(r.object),
                    str(int(r.n)),
                    str(int(r.successes)),
                    _percent(r.rate),
                    _ci(r.wilson_lo, r.wilson_hi),
                ]
                for r in overall.sort_values(["robot", "arm", "object"]).itertuples()
            ],
        )
    )
    tables.append(
        Table(
            "Best settings per robot",
            ["robot", "setting", "n", "successes", "rate", "95% CI", "points compared"],
            [
                [
                    str(r["robot"]),
                    point_label(r, params),
                    str(int(r["n"])),
                    str(int(r["successes"])),
                    _percent(r["rate"]),
                    _ci(r["wilson_lo"], r["wilson_hi"]),
                    str(int(r["points_compared"])),
                ]
                for _, r in best.iterrows()
            ],
            "Ranked by the lower bound of the 95% Wilson interval, pooled over the robot's arms "
            "and objects.",
        )
    )
    tables.append(
        Table(
            "Success per point",
            ["robot", "arm", "object", "setting", "n", "rate", "95% CI", "top failures"],
            [
                [
                    str(r["robot"]),
                    str(r["arm"]),
                    str(r["object"]),
                    point_label(r, params),
                    f"{int(r['successes'])}/{int(r['n'])}",
                    _percent(r["rate"]),
                    _ci(r["wilson_lo"], r["wilson_hi"]),
                    _top_failures(r),
                ]
                for _, r in summary.iterrows()
            ],
        )
    )
    totals = failure_totals(frame)
    if totals.shape[1]:
        tables.append(
            Table(
                "Failure reasons per robot",
                ["robot", *map(str, totals.columns), "total"],
                [
                    [str(robot), *[str(int(v)) for v in values], str(int(sum(values)))]
                    for robot, values in zip(totals.index, totals.to_numpy(), strict=True)
                ],
            )
        )
    messages = error_messages(frame)
    if len(messages):
        tables.append(
            Table(
                "Failure messages",
                ["reason", "message", "episodes", "example episode"],
                [
                    [str(r.failure_reason), str(r.message), str(r.episodes), str(r.example)]
                    for r in messages.itertuples()
                ],
                f"The {MAX_MESSAGES} most frequent messages of failed episodes "
                f"(cut at {MESSAGE_CHARS} characters).",
            )
        )
    stages = funnel(frame)
    tables.append(
        Table(
            "Candidate funnel",
            [
                "robot",
                "episodes",
                "candidates",
                "passed filter",
                "feasible",
                "succeeded",
                "episodes filter ok",
                "episodes feasible",
                "episodes success",
            ],
            [
                [
                    str(r.robot),
                    str(r.episodes),
                    f"{r.candidates_total:,}",
                    f"{r.candidates_passed_filter:,}",
                    f"{r.candidates_feasible:,}",
                    f"{r.candidates_succeeded:,}",
                    _percent(r.episodes_filter_ok),
                    _percent(r.episodes_feasible),
                    _percent(r.episodes_success),
                ]
                for r in stages.itertuples()
            ],
            "Candidate sums over all episodes; the last three columns are shares of episodes "
            "whose filter kept candidates, that found a feasible candidate, that succeeded.",
        )
    )
    return tables


def _overview(run_dir: Path, frame: pd.DataFrame) -> list[tuple[str, str]]:
    runs = sorted(set(frame["run"]) - {""})
    items = [
        ("run", ", ".join(runs) or run_dir.name),
        ("directory", str(run_dir)),
        ("episodes", f"{len(frame)} ({int(frame['success'].sum())} successes)"),
        ("robots", ", ".join(sorted(set(frame["robot"])))),
        ("objects", ", ".join(sorted(set(frame["object"])))),
        ("semantics", ", ".join(sorted(set(frame["semantics"]) - {""})) or "?"),
        ("swept parameters", ", ".join(param_columns(frame.columns)) or "none"),
        ("versions", _versions(frame)),
        ("generated", time.strftime("%Y-%m-%d %H:%M:%S")),
    ]
    skipped = frame.attrs.get("skipped_lines") or []
    if skipped:
        items.append(("unreadable lines skipped", f"{len(skipped)} (lines {skipped[:10]})"))
    return items


def _versions(frame: pd.DataFrame) -> str:
    harness = sorted(set(frame["harness_version"]) - {""})
    mujoco = sorted(set(frame["mujoco_version"]) - {""})
    return f"pick-harness {', '.join(harness) or '?'}; MuJoCo {', '.join(mujoco) or '?'}"


# --------------------------------------------------------------------------------------------
# Markdown and HTML


PLOT_CAPTIONS: dict[str, str] = {
    "success": "Success rate over the swept parameters (cells: successes/episodes)",
    "failures": "Outcome of every episode per point",
    "funnel": "Candidate funnel per robot",
}


def render_markdown(
    run_dir: Path, frame: pd.DataFrame, tables: list[Table], plots: dict[str, Path]
) -> str:
    lines = [f"# pick-harness report: {run_dir.name}", ""]
    lines += [f"- **{key}**: {value}" for key, value in _overview(run_dir, frame)]
    lines.append("")
    for table in tables:
        lines += [f"## {table.title}", ""]
        if table.note:
            lines += [table.note, ""]
        lines += markdown_table(table.header, table.rows)
        lines.append("")
    if plots:
        lines += ["## Plots", ""]
        for name, path in plots.items():
            caption = PLOT_CAPTIONS.get(name, name)
            lines += [f"### {caption}", "", f"![{caption}]({path.relative_to(run_dir)})", ""]
    lines += [
        "Files: `summary.csv` (per point), `best.csv`, `episodes.csv` / `episodes.parquet` "
        "(one row per episode).",
        "",
    ]
    return "\n".join(lines)


HTML_STYLE = """
body { font-family: -apple-system, 'Segoe UI', Helvetica, Arial, sans-serif; color: #1f2328;
       max-width: 1200px; margin: 2em auto; padding: 0 1.5em; line-height: 1.45; }
h1 { border-bottom: 2px solid #d0d7de; padding-bottom: .3em; }
h2 { margin-top: 1.8em; border-bottom: 1px solid #d0d7de; padding-bottom: .2em; }
dl.overview { display: grid; grid-template-columns: max-content auto; gap: .2em 1.2em; }
dl.overview dt { font-weight: 600; color: #57606a; }
dl.overview dd { margin: 0; }
table { border-collapse: collapse; margin: .6em 0 1em; font-size: 0.92em; }
th, td { border: 1px solid #d0d7de; padding: .3em .65em; text-align: left; }
th { background: #f6f8fa; }
tr:nth-child(even) td { background: #fbfcfd; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
p.note { color: #57606a; font-size: .9em; margin: .2em 0; }
figure { margin: 1em 0 2em; }
figure img { max-width: 100%; border: 1px solid #d0d7de; border-radius: 6px; }
figcaption { color: #57606a; font-size: .9em; margin-top: .3em; }
"""


def render_html(
    run_dir: Path, frame: pd.DataFrame, tables: list[Table], plots: dict[str, Path]
) -> str:
    """A self-contained page: the tables, and the plots embedded as base64 PNG."""
    esc = html.escape
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>pick-harness report: {esc(run_dir.name)}</title>",
        f"<style>{HTML_STYLE}</style></head><body>",
        f"<h1>pick-harness report: {esc(run_dir.name)}</h1>",
        '<dl class="overview">',
    ]
    for key, value in _overview(run_dir, frame):
        parts.append(f"<dt>{esc(key)}</dt><dd>{esc(str(value))}</dd>")
    parts.append("</dl>")
    for name, path in plots.items():
        if name == "success":  # the headline plot first
            parts.append(_html_figure(name, path))
    for table in tables:
        parts.append(f"<h2>{esc(table.title)}</h2>")
        if table.note:
            parts.append(f'<p class="note">{esc(table.note)}</p>')
        parts.append("<table><thead><tr>")
        parts += [f"<th>{esc(h)}</th>" for h in table.header]
        parts.append("</tr></thead><tbody>")
        for row in table.rows:
            cells = [
                f'<td class="num">{esc(c)}</td>' if _numeric(c) else f"<td>{esc(c)}</td>"
                for c in row
            ]
            parts.append("<tr>" + "".join(cells) + "</tr>")
        parts.append("</tbody></table>")
    others = {name: path for name, path in plots.items() if name != "success"}
    if others:
        parts.append("<h2>Plots</h2>")
        parts += [_html_figure(name, path) for name, path in others.items()]
    parts.append("</body></html>")
    return "\n".join(parts)


def _numeric(text: str) -> bool:
    stripped = text
    for mark in ("%", "/", "–", ".", ","):
        stripped = stripped.replace(mark, "")
    return bool(stripped) and stripped.replace("-", "").isdigit()


def _html_figure(name: str, path: Path) -> str:
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    caption = html.escape(PLOT_CAPTIONS.get(name, name))
    return (
        f'<figure><img alt="{caption}" src="data:image/png;base64,{data}">'
        f"<figcaption>{caption}</figcaption></figure>"
    )


# --------------------------------------------------------------------------------------------
# Build


def build_report(run_dir: str | Path, export: bool = False) -> ReportPaths:
    """Rebuild summary.csv, best.csv, plots/, report.md and report.html of ``run_dir``.

    With ``export`` the store is also re-exported to episodes.csv / episodes.parquet (only when
    it has an ``episodes.jsonl``; a hand-made episodes.csv is never overwritten).
    """
    from harness.report.plots import plot_failures, plot_funnel, plot_success

    run_dir = Path(run_dir)
    frame = load_episodes(run_dir)
    if export and (run_dir / JSONL_NAME).is_file():
        ResultStore(run_dir).export()
    summary = summarize(frame)
    best = best_settings(summary)
    summary_csv = run_dir / SUMMARY_NAME
    best_csv = run_dir / BEST_NAME
    summary.to_csv(summary_csv, index=False)
    best.to_csv(best_csv, index=False)

    plots_dir = run_dir / "plots"
    plots_dir.mkdir(exist_ok=True)
    plots = {
        "success": plot_success(summary, plots_dir / "success.png"),
        "failures": plot_failures(summary, plots_dir / "failures.png"),
        "funnel": plot_funnel(funnel(frame), plots_dir / "funnel.png"),
    }
    tables = report_tables(frame, summary, best)
    report_md = run_dir / "report.md"
    report_html = run_dir / "report.html"
    report_md.write_text(render_markdown(run_dir, frame, tables, plots), encoding="utf-8")
    report_html.write_text(render_html(run_dir, frame, tables, plots), encoding="utf-8")
    return ReportPaths(run_dir, summary_csv, best_csv, report_md, report_html, plots)
