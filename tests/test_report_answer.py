"""The report answers first, by one objective (issue 36).

The fixture sweep (tests/fixtures/sweep_episodes.csv, see tests/test_report.py) gets validity
columns by hand: fr3's point 2 (downward 140, pre-grasp 0.05) is 5/5 reference but only 1/5
valid (four fingers in the table), point 0 (downward 140, 0.10) is 4/5 and 4/5. So the
reference-best and the valid-best setting differ, and the objective alone decides which one the
first screen recommends and how the heatmap colours the cells.
"""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from harness.report import build_report, summarize
from harness.report.answer import NO_SETTING, UNCONFIRMED, sweep_answers
from harness.report.objective import RECORD_NAME

FIXTURE = Path(__file__).parent / "fixtures" / "sweep_episodes.csv"
POINT_0 = "approach_filter=downward 140, pre_grasp_offset=0.1"
POINT_2 = "approach_filter=downward 140, pre_grasp_offset=0.05"


def validity_run(folder: Path) -> Path:
    """The fixture run with validity columns: fr3 point 2 valid in 1 of its 5 successes."""
    folder.mkdir(parents=True)
    frame = pd.read_csv(FIXTURE, keep_default_na=False)
    frame["valid"] = frame["success"].astype(str) == "True"
    frame["invalid_reason"] = ["" if v else "not_run" for v in frame["valid"]]
    fr3_2 = (frame["robot"] == "fr3") & (frame["point_id"] == 2)
    through = fr3_2 & (frame.groupby(fr3_2).cumcount() < 4)
    frame.loc[through, "valid"] = False
    frame.loc[through, "invalid_reason"] = "table_penetration"
    frame.to_csv(folder / "episodes.csv", index=False)
    return folder


def answer_rows(page: str) -> dict[str, list[str]]:
    """The first answer table of a page: unit -> its cells (text)."""
    table = page[page.index('<table class="answer">') :]
    table = table[: table.index("</table>")]
    rows = {}
    for row in re.findall(r"<tr>(.*?)</tr>", table, re.S)[1:]:
        cells = [re.sub(r"<[^>]+>", "", c) for c in re.findall(r"<td[^>]*>(.*?)</td>", row, re.S)]
        rows[cells[0]] = cells
    return rows


def heatmap_cells(page: str, robot: str, arm: str, obj: str) -> dict[tuple[str, str], float]:
    """The colour value of each (x, y) cell of one plotly heatmap on the page."""
    start = page.index(f'id="heatmap-{robot}-{arm}-{obj}"')
    script = page[start : page.index("</script>", start)]
    z = json.loads(re.search(r'"z":(\[\[.*?\]\])', script).group(1))  # type: ignore[union-attr]
    x = json.loads(re.search(r'"x":(\[.*?\])', script).group(1))  # type: ignore[union-attr]
    y = json.loads(re.search(r'"y":(\[.*?\])', script).group(1))  # type: ignore[union-attr]
    return {(xv, yv): z[i][j] for i, yv in enumerate(y) for j, xv in enumerate(x)}


def test_the_objective_picks_the_answer_and_colours_the_heatmap(tmp_path: Path) -> None:
    run = validity_run(tmp_path / "run")
    page = build_report(run).report_html.read_text(encoding="utf-8")  # default: valid
    fr3 = answer_rows(page)["fr3 left cube"]
    assert fr3[2] == POINT_0 and fr3[3] == "valid 4/5 (80%, 0.38–0.96)"
    assert fr3[4].startswith("reference 4/5")  # the other rate beside it
    assert fr3[5].startswith("approach_filter=downward 120, pre_grasp_offset=0.1: valid 2/5")
    cells = heatmap_cells(page, "fr3", "left", "cube")
    assert cells[("downward 140", "0.05")] == pytest.approx(0.2)  # point 2: 1/5 valid
    assert cells[("downward 140", "0.1")] == pytest.approx(0.8)
    assert json.loads((run / RECORD_NAME).read_text())["objective"] == "valid"
    assert pd.read_csv(run / "best.csv").set_index("robot").loc["fr3", "point_id"] == 0

    page = build_report(run, objective="reference").report_html.read_text(encoding="utf-8")
    fr3 = answer_rows(page)["fr3 left cube"]
    assert fr3[2] == POINT_2 and fr3[3] == "reference 5/5 (100%, 0.57–1.00)"
    assert fr3[4].startswith("valid 1/5")
    cells = heatmap_cells(page, "fr3", "left", "cube")
    assert cells[("downward 140", "0.05")] == pytest.approx(1.0)
    # the run keeps its objective: a report without the flag ranks by reference again
    again = build_report(run)
    assert again.objective == "reference"
    assert answer_rows(again.report_html.read_text(encoding="utf-8"))["fr3 left cube"][2] == POINT_2


def test_the_first_section_holds_the_answer_and_the_rest_is_folded(tmp_path: Path) -> None:
    paths = build_report(validity_run(tmp_path / "run"))
    page = paths.report_html.read_text(encoding="utf-8")
    body = page[page.index("<body>") :]
    assert body.index('<section id="answer">') < body.index("<details")
    answer = body[body.index('<section id="answer">') : body.index("</section>")]
    assert "which setting, how sure, why the rest fail" in answer
    assert UNCONFIRMED in answer and "runner-up" in answer and "why the rest" in answer
    assert 'dl class="overview"' not in body[: body.index("<details")]  # metadata folded
    # every table after the answer sits in a section of its own that folds
    sections = body.split('<details class="section" id=')
    assert '<table class="sortable">' not in sections[0]
    assert all(part.count('<table class="sortable">') <= 1 for part in sections[1:])
    assert sum(part.count('<table class="sortable">') for part in sections) > 5
    markdown = paths.report_md.read_text(encoding="utf-8")
    headings = re.findall(r"^## (.*)$", markdown, re.M)
    assert headings[:2] == [
        "Answer: which setting, how sure, why the rest fail",
        "Summary: what to change",
    ]
    assert f"| fr3 left cube | best swept setting (untested) | {POINT_0} |" in markdown


def test_no_setting_helps_names_the_dominant_cause(tmp_path: Path) -> None:
    run = validity_run(tmp_path / "run")
    frame = pd.read_csv(run / "episodes.csv", keep_default_na=False)
    fr3 = frame["robot"] == "fr3"
    frame.loc[fr3 & frame["valid"], "invalid_reason"] = "table_penetration"
    frame.loc[fr3, "valid"] = False
    summary = summarize(frame)
    params = ["param.pick.approach_filter", "param.pick.pre_grasp_offset"]
    by_unit = {a.unit: a for a in sweep_answers(summary, "valid", params)}
    fr3_answer = by_unit["fr3 left cube"]
    # 11 reference successes, all through the table; 4 failures (dropped, no_contact)
    assert fr3_answer.decision == f"{NO_SETTING}: table_penetration"
    assert fr3_answer.rate == "valid 0/15 over all settings (0%, 0.00–0.20)"
    assert fr3_answer.other_rate == "reference 11/15 (73%) over all settings"
    assert fr3_answer.reason.startswith("15 of 15 miss: table_penetration 11")
    assert by_unit["split_aloha left cube"].decision.startswith("best swept setting")
    # by the reference verdict the same unit has a best setting
    by_reference = {a.unit: a for a in sweep_answers(summary, "reference", params)}
    assert by_reference["fr3 left cube"].setting == POINT_2


def test_a_tune_page_puts_its_decisions_first_and_a_sweep_links_to_it(tmp_path: Path) -> None:
    """decisions.csv is read as it comes: a column the page does not know (``cause``,
    ``detectable_gain``) still shows, and "undecided" says how many seeds it needs."""
    tune = tmp_path / "reports" / "tune-fr3"
    validity_run(tune / "screen")
    (tune / "tune").mkdir()
    (tune / "tune.json").write_text(json.dumps({"objective": "valid", "sources": {}}))
    decisions = pd.DataFrame(
        [
            {"robot": "fr3", "arm": "left", "object": "cube", "task": "fr3_left_cube",
             "verdict": "undecided within budget", "setting": "approach downward 140",
             "n": 40, "successes": 30, "rate": 0.75, "lo": 0.6, "hi": 0.86,
             "reference_rate": 0.9, "contenders": "approach downward 120 (33/40)",
             "seeds_needed": 120, "reason": "budget spent", "detectable_gain": 0.25},
            {"robot": "split_aloha", "arm": "left", "object": "cube",
             "task": "split_aloha_left_cube", "verdict": "no setting helps",
             "cause": "table_penetration", "setting": "approach downward 140", "n": 20,
             "successes": 0, "rate": 0.0, "lo": 0.0, "hi": 0.16, "reference_rate": 0.8,
             "contenders": "", "seeds_needed": 0, "reason": "", "detectable_gain": 0.3},
        ]
    )  # fmt: skip
    decisions.to_csv(tune / "tune" / "decisions.csv", index=False)
    page = build_report(tune / "screen").report_html.read_text(encoding="utf-8")
    assert page.index("Tune decisions: which setting") < page.index("Screening candidates")
    rows = answer_rows(page)
    assert rows["fr3 left cube"][1] == "undecided: needs 120 seeds"
    assert rows["fr3 left cube"][3] == "valid 30/40 (75%, 0.60–0.86)"
    assert "detectable_gain: 0.25" in rows["fr3 left cube"][6]
    assert rows["split_aloha left cube"][1] == "no setting helps: table_penetration"
    assert "<th>detectable_gain</th>" in page and "<th>cause</th>" in page
    assert "pick-harness tune: tune-fr3" in page

    sweep = tmp_path / "reports" / "sweep"
    shutil.copytree(tune / "screen", sweep, ignore=shutil.ignore_patterns("report*", "*.png"))
    sweep_page = build_report(sweep).report_html.read_text(encoding="utf-8")
    link = '<a href="../tune-fr3/screen/report.html">tune-fr3 (decided on fresh seeds)</a>'
    assert link in sweep_page
    assert "Tune decisions" not in sweep_page


def test_the_sweep_recording_names_one_series_per_arm_object_and_setting(tmp_path: Path) -> None:
    from helpers import blueprint_views, read_back
    from rerun.chunk import RrdReader

    from harness.viz.sweep_recording import record_sweep

    run = validity_run(tmp_path / "run")
    build_report(run)
    path = record_sweep(run, "valid")
    assert path is not None
    entities, _ = read_back(path)
    series = sorted(e for e in entities if e.startswith("/compare/"))
    assert len(series) == 9  # 3 arms x 3 settings, one object
    for entity in series:
        assert entities[entity]["Scalars:scalars"] == 5  # running rate over its 5 episodes
    names: dict[str, list[str]] = {}
    last: dict[str, float] = {}
    for chunk in RrdReader(str(path)).stream().to_chunks():
        batch = chunk.to_record_batch()
        if not chunk.entity_path.startswith("/compare/"):
            continue
        if "SeriesLines:names" in batch.schema.names:
            names[chunk.entity_path] = batch.column("SeriesLines:names").to_pylist()[0]
        if "Scalars:scalars" in batch.schema.names:
            last[chunk.entity_path] = batch.column("Scalars:scalars").to_pylist()[-1][0]
    assert sorted(names) == series
    labels = [n[0] for n in names.values()]
    assert len(set(labels)) == 3  # each arm's three settings, named the same across arms
    fr3 = sorted(n[0] for e, n in names.items() if e.startswith("/compare/fr3/"))
    assert fr3 == [
        "approach_filter=downward 120, pre_grasp_offset=0.1 (valid)",
        "approach_filter=downward 140, pre_grasp_offset=0.05 (valid)",
        "approach_filter=downward 140, pre_grasp_offset=0.1 (valid)",
    ]
    point_2 = "/compare/fr3/left/cube/approach_filter_downward_140_pre_grasp_offset_0.05"
    assert last[point_2] == pytest.approx(0.2)  # its valid rate after all 5 episodes
    views = blueprint_views(path)
    assert {"/compare/fr3/left/cube", "/compare/split_aloha/left/cube"} <= set(views)
    assert views["/compare/fr3/left/cube"] == "TimeSeries"


def test_the_tune_heatmap_png_is_laid_out_as_the_page() -> None:
    """Approach settings are the columns (x) and facing settings the rows (y, first at the
    bottom), as the page's plotly heatmap puts the first swept axis on x."""
    from harness.tuning.heatmaps import grid

    table = pd.DataFrame(
        {
            "approach": ['["downward", 120]', '["downward", 140]', '["downward", 120]'],
            "facing": ['["forward", 90]', '["forward", 90]', '["forward", 60]'],
            "successes": [3, 5, 1],
            "n": [5, 5, 5],
        }
    )
    table["rate"] = table["successes"] / table["n"]
    cols, rows, rates, counts = grid(table)
    assert cols == ['["downward", 120]', '["downward", 140]']
    assert rows == ['["forward", 60]', '["forward", 90]']
    assert rates[1, 1] == pytest.approx(1.0) and counts[(0, 0)] == "1/5"
    assert rates.shape == (2, 2) and np.isnan(rates[0, 1])


def test_compare_defaults_to_valid_and_says_when_it_falls_back(tmp_path: Path) -> None:
    from harness.report import compare_runs

    run = validity_run(tmp_path / "run")
    valid = compare_runs(run, run).set_index(["robot", "point_id"])
    assert set(valid["verdict"]) == {"valid"}
    assert (valid.loc[("fr3", 2), "successes_a"], valid.loc[("fr3", 2), "n_a"]) == (1, 5)
    plain = tmp_path / "plain"
    plain.mkdir()
    shutil.copy(FIXTURE, plain / "episodes.csv")  # no validity columns: nothing judged
    fallback = compare_runs(plain, plain).set_index(["robot", "point_id"])
    assert set(fallback["verdict"]) == {"reference"}
    assert fallback.loc[("fr3", 2), "successes_a"] == 5
