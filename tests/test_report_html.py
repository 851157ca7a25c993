"""The interactive report of a real small sweep (issue 14): self-contained HTML, one heatmap per
robot, arm and object, error rows out of the rates and in their own table, the reference
fallback flagged, seeds in full, episode ids linked to their recordings, replayed videos."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pandas as pd
import pytest

from harness.api import sweep
from harness.cli import main as cli_main
from harness.report import build_report, load_episodes, summarize
from harness.report.sections import FALLBACK_MARK
from harness.runs.store import ResultStore
from harness.viz.headline import outcome_class

ROOT = Path(__file__).resolve().parents[1]
TASKS = ROOT / "tasks" / "pick"
# Both arms of Split ALOHA, two approach cones, two objects, one episode per point.
SWEEP = {
    "name": "report-html",
    "tasks": [str(TASKS / f"{name}.yaml") for name in ("split_aloha_left", "split_aloha_right")],
    "axes": {
        "pick.approach_filter": [["downward", 140], ["downward", 160]],
        "object.mesh": ["cube", "banana"],
    },
    "episodes_per_point": 1,
    "seed": 0,
    "record": "all",
}  # fmt: skip
EXTERNAL = re.compile(r"<(?:script|link|img|video|source|iframe)\b[^>]*(?:src|href)=\"https?:")


@pytest.fixture(scope="module")
def real_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    run_dir = tmp_path_factory.mktemp("report-html") / "run"
    sweep(SWEEP, out=run_dir, backend="serial")
    return run_dir


def copy_run(source: Path, target: Path) -> Path:
    shutil.copytree(source, target, ignore=shutil.ignore_patterns(".lock"))
    return target


def test_the_page_is_self_contained_with_a_heatmap_per_robot_arm_and_object(
    real_run: Path,
) -> None:
    page = (real_run / "report.html").read_text(encoding="utf-8")
    assert EXTERNAL.search(page) is None, "the page loads something from the network"
    assert "<link" not in page and 'src="plots/' not in page
    assert "Plotly.newPlot" in page and len(page) > 1_000_000  # plotly.js itself, inline
    frame = load_episodes(real_run)
    groups = {(r.robot, r.arm, r.object) for r in frame.itertuples()}
    assert len(groups) == 4  # split_aloha left and right x cube and banana
    heatmaps = set(re.findall(r'id="heatmap-([a-z0-9_]+)-(left|right)-([a-z0-9_]+)"', page))
    assert heatmaps == groups
    first = page.index('id="heatmap-')
    hover = page[first : page.index("</script>", first)]
    assert "95% CI" in hover and "failures: " in hover  # the hover details, per cell
    assert 'class="sortable"' in page and "addEventListener('click'" in page
    best = pd.read_csv(real_run / "best.csv")
    assert len(best) == 4 and set(best["points_compared"]) == {2}
    assert [c for c in best.columns if c.startswith("param.")] == ["param.pick.approach_filter"]


def test_seeds_in_full_and_episode_ids_linked_to_their_recordings(real_run: Path) -> None:
    frame = load_episodes(real_run)
    page = (real_run / "report.html").read_text(encoding="utf-8")
    markdown = (real_run / "report.md").read_text(encoding="utf-8")
    examples = page[page.index("<h2>Example episodes</h2>") :]
    examples = examples[: examples.index("</table>")]
    shown = re.findall(r'<a href="(episodes/[^"]+\.rrd)"[^>]*>([^<]+)</a>', examples)
    assert shown, "no example episode links to its recording"
    by_id = frame.set_index("episode_id")
    for href, episode in shown:
        assert by_id.loc[episode, "recording"] == href and (real_run / href).is_file()
        seed = str(int(by_id.loc[episode, "seed"]))
        assert len(seed) > 8 and f'<td class="num">{seed}</td>' in examples
        assert f"[{episode}]({href})" in markdown


def test_error_rows_are_left_out_of_rates_and_listed(real_run: Path, tmp_path: Path) -> None:
    run = copy_run(real_run, tmp_path / "with-error")
    before = summarize(load_episodes(run)).set_index(["task", "point_id"])
    row = ResultStore(run).load().iloc[0].to_dict()
    injected = {
        **row,
        "episode_id": row["episode_id"] + "-crashed",
        "seed": 12345678901234567,
        "success": False,
        "failure_reason": "error",
        "error_message": "RuntimeError: worker crashed twice (injected)",
        "recording": None,
    }
    ResultStore(run).append(injected)
    paths = build_report(run, export=True)
    after = pd.read_csv(paths.summary_csv).set_index(["task", "point_id"])
    key = (row["task"], row["point_id"])
    assert after.loc[key, "errors"] == 1 and before.loc[key, "errors"] == 0
    for name in ("n", "successes", "rate", "wilson_lo", "fail.error"):
        assert after.loc[key, name] == before.loc[key, name], name
    assert (after.drop(index=[key])["errors"] == 0).all()
    page = paths.report_html.read_text(encoding="utf-8")
    errors = page[page.index("<h2>Error rows (left out of every rate)</h2>") :]
    errors = errors[: errors.index("</table>")]
    assert "worker crashed twice (injected)" in errors and ">12345678901234567<" in errors
    assert "1 error rows left out of every rate" in page


def test_a_run_of_error_rows_only_still_reports(real_run: Path, tmp_path: Path) -> None:
    """Every episode re-stored as an error (the last row of an id wins): no rate anywhere, the
    report is still written and lists each of them."""
    run = copy_run(real_run, tmp_path / "all-errors")
    store = ResultStore(run)
    for row in store.load().to_dict("records"):
        store.append({**row, "success": False, "failure_reason": "error",
                      "error_message": "ConfigError: injected"})  # fmt: skip
    paths = build_report(run, export=True)
    summary = pd.read_csv(paths.summary_csv)
    assert (summary["n"] == 0).all() and (summary["errors"] == 1).all()
    assert summary["rate"].isna().all()
    page = paths.report_html.read_text(encoding="utf-8")
    assert page.count("ConfigError: injected") == len(summary)


def test_the_reference_fallback_is_flagged(tmp_path: Path, capsys) -> None:
    """No pose has both EE x and z within 5 degrees of up: the filter keeps nothing, the
    reference falls back to poses 0..19 (filter_outcome ``fallback``); the report flags it."""
    run = tmp_path / "fallback"
    args = ["run", str(TASKS / "fr3.yaml"), "--episodes", "1", "--record", "none", "--out",
            str(run), "--set", "pick.filter_x_dir=[upward,5]",
            "--set", "pick.filter_z_dir=[upward,5]"]  # fmt: skip
    assert cli_main(args) == 0
    frame = load_episodes(run)
    assert frame["filter_outcome"].tolist() == ["fallback"]
    out = capsys.readouterr().out
    assert str(int(frame["seed"].iloc[0])) in out  # the full seed
    assert "reference fallback in 1 episode(s)" in out
    summary = pd.read_csv(run / "summary.csv")
    assert summary["fallback"].tolist() == [1]
    page = (run / "report.html").read_text(encoding="utf-8")
    assert '<tr class="flag">' in page and f"{FALLBACK_MARK} 1/1" in page
    markdown = (run / "report.md").read_text(encoding="utf-8")
    assert f"{FALLBACK_MARK} 1/1" in markdown


def test_no_fallback_no_flag(real_run: Path) -> None:
    frame = load_episodes(real_run)
    assert set(frame["filter_outcome"]) == {"ok"}
    page = (real_run / "report.html").read_text(encoding="utf-8")
    assert '<tr class="flag">' not in page and f"{FALLBACK_MARK} " not in page.split("<table")[1]


@pytest.mark.slow
def test_videos_of_each_outcome_class_and_per_arm_kept_without_rendering(
    real_run: Path, tmp_path: Path
) -> None:
    """One video per outcome class and one success and one failure per arm, each with its
    poster and recording; a later ``report --no-videos`` keeps them on the page."""
    imageio = pytest.importorskip("imageio.v3")
    run = copy_run(real_run, tmp_path / "videos")
    paths = build_report(run, videos=True)
    frame = load_episodes(run)
    classes = {outcome_class(row) for _, row in frame.iterrows()}
    assert {clip.outcome_class for clip in paths.videos} == classes
    per_arm = 0
    for _, group in frame.groupby(["robot", "arm"]):
        per_arm += int(group["success"].any()) + int((~group["success"]).any())
    assert max(len(classes), per_arm) <= len(paths.videos) <= len(classes) + per_arm
    for clip in paths.videos:
        assert clip.path is not None, clip.note
        assert clip.note == ""  # the replay reproduced the stored verdict
        frames = imageio.imread(run / clip.path)
        assert frames.shape[0] == clip.frames and frames.shape[1:3] == (480, 640)  # readable
        assert clip.poster is not None and imageio.imread(run / clip.poster).shape == (480, 640, 3)
        assert clip.headline and clip.headline.split(":")[0] in {
            "SUCCESS · VALID", "REFERENCE SUCCESS · INVALID", "FAILURE"
        }  # fmt: skip
    page = paths.report_html.read_text(encoding="utf-8")
    expected = len(paths.videos)
    assert page.count('src="data:video/mp4;base64,') == expected
    assert page.count('poster="data:image/png;base64,') == expected
    videos = page[page.index("<h2>Videos") :]
    recordings = frame.set_index("episode_id")["recording"]
    for clip in paths.videos:  # every episode of this run was recorded: captions link to them
        assert f'<a href="{recordings[clip.episode_id]}" title="recording">' in videos
    again = build_report(run, videos=False)  # harness report --no-videos
    assert [c.episode_id for c in again.videos] == [c.episode_id for c in paths.videos]
    kept = again.report_html.read_text(encoding="utf-8")
    assert kept.count('src="data:video/mp4;base64,') == expected


def test_the_page_opens_on_a_summary_and_contents_with_filterable_tables(real_run: Path) -> None:
    page = (real_run / "report.html").read_text(encoding="utf-8")
    summary, contents = page.index('id="summary"'), page.index("<h2>Contents</h2>")
    assert summary < contents < page.index('id="heatmaps"')
    assert page.count('<input class="filter"') == page.count('<table class="sortable">') > 3
    assert "harness view" in page and "rerun --web-viewer" in page  # how to open recordings
    assert (real_run / "plots" / "placement.png").is_file() and 'id="placement"' in page


def test_a_hostile_task_name_is_escaped_in_the_page(real_run: Path, tmp_path: Path) -> None:
    run = copy_run(real_run, tmp_path / "hostile")
    hostile = "<script>alert('pwned')</script>&<b>"
    jsonl = run / "episodes.jsonl"
    rows = [json.loads(line) for line in jsonl.read_text(encoding="utf-8").splitlines()]
    for row in rows:
        row["task"] = row["run"] = hostile
        row["error_message"] = hostile if row["error_message"] else ""
    jsonl.write_text("".join(json.dumps(r) + "\n" for r in rows), encoding="utf-8")
    paths = build_report(run, export=True)
    page = paths.report_html.read_text(encoding="utf-8")
    assert hostile not in page and "<script>alert(" not in page
    assert "&lt;script&gt;alert(&#39;pwned&#39;)&lt;/script&gt;&amp;&lt;b&gt;" in page
