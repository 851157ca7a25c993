"""Reports against hand computation on a fixture CSV; statistics; compare; the CLI commands.

The fixture (tests/fixtures/sweep_episodes.csv) is a strict-semantics sweep of two robots over
three points (approach_filter x pre_grasp_offset), 5 episodes per point and arm: fr3 (left arm)
and split_aloha (left and right arms). Its outcomes, written down by hand:

    point                   fr3 left            split_aloha left            split_aloha right
    0 downward 140, 0.10    4/5 dropped         4/5 no_feasible_candidate   3/5 dropped, timeout
    1 downward 120, 0.10    2/5 2 no_contact,   1/5 3 filter_empty,         0/5 5 filter_empty
                                plan_failed         dropped
    2 downward 140, 0.05    5/5                 3/5 2 collision             5/5
"""

from __future__ import annotations

import base64
import json
import re
import shutil
from pathlib import Path

import pandas as pd
import pytest

from harness.cli import main as cli_main
from harness.errors import HarnessError
from harness.failures import FAILURE_REASONS
from harness.report import (
    best_settings,
    build_report,
    compare_runs,
    failure_totals,
    funnel,
    load_episodes,
    pooled,
    summarize,
)
from harness.report.stats import (
    Z_95,
    compare_proportions,
    fisher_exact_p,
    two_proportion_z_test,
    wilson_interval,
)
from harness.runs.store import ResultStore

FIXTURE = Path(__file__).parent / "fixtures" / "sweep_episodes.csv"

# Wilson 95% bounds, computed independently (closed form, z = 1.959964).
WILSON = {
    (0, 5): (0.0, 0.4345),
    (1, 5): (0.0362, 0.6245),
    (2, 5): (0.1176, 0.7693),
    (3, 5): (0.2307, 0.8824),
    (4, 5): (0.3755, 0.9638),
    (5, 5): (0.5655, 1.0),
    (7, 10): (0.3968, 0.8922),
    (8, 10): (0.4902, 0.9433),
    (1, 10): (0.0179, 0.4042),
}
# (robot, arm, point_id) -> (successes, {reason: count}), 5 episodes each.
EXPECTED = {
    ("fr3", "left", 0): (4, {"dropped": 1}),
    ("fr3", "left", 1): (2, {"no_contact": 2, "plan_failed": 1}),
    ("fr3", "left", 2): (5, {}),
    ("split_aloha", "left", 0): (4, {"no_feasible_candidate": 1}),
    ("split_aloha", "left", 1): (1, {"filter_empty": 3, "dropped": 1}),
    ("split_aloha", "left", 2): (3, {"collision": 2}),
    ("split_aloha", "right", 0): (3, {"dropped": 1, "timeout": 1}),
    ("split_aloha", "right", 1): (0, {"filter_empty": 5}),
    ("split_aloha", "right", 2): (5, {}),
}


@pytest.fixture
def fixture_run(tmp_path: Path) -> Path:
    run_dir = tmp_path / "fixture-run"
    run_dir.mkdir()
    shutil.copy(FIXTURE, run_dir / "episodes.csv")
    return run_dir


def modified_run(source: Path, target: Path, edit) -> Path:
    target.mkdir()
    frame = edit(pd.read_csv(source / "episodes.csv", keep_default_na=False))
    frame.to_csv(target / "episodes.csv", index=False)
    return target


# --------------------------------------------------------------------------------------------
# Statistics


@pytest.mark.parametrize(("counts", "bounds"), WILSON.items())
def test_wilson_interval_matches_known_values(counts, bounds) -> None:
    low, high = wilson_interval(*counts)
    assert low == pytest.approx(bounds[0], abs=5e-5)
    assert high == pytest.approx(bounds[1], abs=5e-5)


def test_wilson_edge_cases() -> None:
    assert wilson_interval(0, 0) == (0.0, 1.0)
    low, high = wilson_interval(7, 10, confidence=0.99)
    assert low < 0.3968 and high > 0.8922
    with pytest.raises(ValueError):
        wilson_interval(6, 5)


@pytest.mark.parametrize(("confidence", "largest"), [(0.95, 100), (0.99, 30)])
def test_wilson_interval_is_scipys_bit_for_bit(confidence: float, largest: int) -> None:
    """The interval is computed without scipy.stats (its import is ~0.5 s of every report), so
    it must be scipy's binomtest Wilson interval float for float, at every count up to n = 100."""
    from scipy import stats as scipy_stats
    from scipy.special import ndtri

    assert float(ndtri(0.975)) == Z_95
    for n in range(1, largest + 1):
        for k in range(n + 1):
            ci = scipy_stats.binomtest(k, n).proportion_ci(confidence, method="wilson")
            low = 0.0 if k == 0 else max(0.0, float(ci.low))
            high = 1.0 if k == n else min(1.0, float(ci.high))
            assert wilson_interval(k, n, confidence) == (low, high), (k, n)


def test_two_proportion_tests_match_hand_computation() -> None:
    # 30/50 vs 40/50: pooled p = 0.7, se = sqrt(0.7 * 0.3 * (2 / 50)) = 0.091652, z = 2.1822.
    z, p = two_proportion_z_test(30, 50, 40, 50)
    assert z == pytest.approx(2.18218, abs=1e-5)
    assert p == pytest.approx(0.029096, abs=1e-6)
    assert two_proportion_z_test(5, 5, 5, 5) == (0.0, 1.0)
    # Fisher: 3/5 vs 5/5 -> hypergeometric tables with k1 = 3 or 5 are as extreme: 20/45.
    assert fisher_exact_p(3, 5, 5, 5) == pytest.approx(20 / 45)
    small = compare_proportions(3, 5, 5, 5)
    assert (small.test, small.difference) == ("fisher", pytest.approx(0.4))
    large = compare_proportions(30, 50, 40, 50)
    assert large.test == "z" and large.p_value == pytest.approx(0.029096, abs=1e-6)


# --------------------------------------------------------------------------------------------
# Summary, best settings, failures, funnel


def test_summary_equals_hand_computation(fixture_run: Path) -> None:
    summary = summarize(load_episodes(fixture_run))
    assert len(summary) == 9
    assert summary["n"].tolist() == [5] * 9
    for _, row in summary.iterrows():
        successes, failures = EXPECTED[(row["robot"], row["arm"], row["point_id"])]
        assert row["successes"] == successes
        assert row["rate"] == pytest.approx(successes / 5)
        assert (row["wilson_lo"], row["wilson_hi"]) == pytest.approx(
            WILSON[(successes, 5)], abs=5e-5
        )
        for reason in FAILURE_REASONS:
            assert row[f"fail.{reason}"] == failures.get(reason, 0), reason
        assert row["successes"] + sum(row[f"fail.{r}"] for r in FAILURE_REASONS) == row["n"]
    point_2 = summary[(summary["robot"] == "fr3") & (summary["point_id"] == 2)].iloc[0]
    assert point_2["param.pick.approach_filter"] == '["downward", 140]'
    assert point_2["param.pick.pre_grasp_offset"] == 0.05
    assert json.loads(point_2["point"]) == {
        "pick.approach_filter": ["downward", 140],
        "pick.pre_grasp_offset": 0.05,
    }


def test_pooling_and_best_settings(fixture_run: Path) -> None:
    summary = summarize(load_episodes(fixture_run))
    per_point = pooled(summary[summary["robot"] == "split_aloha"], ["point_id"])
    by_point = per_point.set_index("point_id")
    assert (by_point.loc[0, "successes"], by_point.loc[0, "n"]) == (7, 10)
    assert (by_point.loc[0, "wilson_lo"], by_point.loc[0, "wilson_hi"]) == pytest.approx(
        (0.3968, 0.8922), abs=5e-5
    )
    best = best_settings(summary, "reference").set_index(["robot", "arm"])
    # fr3: 5/5 at point 2 (lower bound 0.5655) beats 4/5 at point 0 (0.3755).
    assert best.loc[("fr3", "left"), "point_id"] == 2
    assert (best.loc[("fr3", "left"), "successes"], best.loc[("fr3", "left"), "n"]) == (5, 5)
    assert best.loc[("fr3", "left"), "wilson_lo"] == pytest.approx(0.5655, abs=5e-5)
    # split_aloha, arms never pooled: the left arm's best is point 0 (4/5, 0.3755 beats 3/5 at
    # point 2), the right arm's is point 2 (5/5); pooled, point 2 (8/10) would hide the left.
    assert best.loc[("split_aloha", "left"), "point_id"] == 0
    assert best.loc[("split_aloha", "left"), "wilson_lo"] == pytest.approx(0.3755, abs=5e-5)
    assert best.loc[("split_aloha", "right"), "point_id"] == 2
    assert (best["points_compared"] == 3).all()
    # the object is not a setting: the label columns are the swept settings only
    assert [c for c in best.columns if c.startswith("param.")] == [
        "param.pick.approach_filter",
        "param.pick.pre_grasp_offset",
    ]


def test_best_setting_prefers_the_lower_bound_over_the_raw_rate() -> None:
    summary = pd.DataFrame(
        {
            "task": ["t", "t"],
            "robot": ["fr3", "fr3"],
            "arm": ["left", "left"],
            "object": ["cube", "cube"],
            "point": ['{"a": 1}', '{"a": 2}'],
            "point_id": [0, 1],
            "param.a": [1, 2],
            "n": [2, 20],
            "successes": [2, 18],
        }
    )
    best = best_settings(summary)
    assert best.loc[0, "point_id"] == 1  # 18/20 (lower bound 0.699) beats 2/2 (0.342)


def test_failure_totals_and_funnel(fixture_run: Path) -> None:
    frame = load_episodes(fixture_run)
    totals = failure_totals(frame)
    assert totals.loc["fr3"].to_dict() == {
        "filter_empty": 0,
        "no_feasible_candidate": 0,
        "plan_failed": 1,
        "collision": 0,
        "no_contact": 2,
        "dropped": 1,
        "timeout": 0,
    }
    assert totals.loc["split_aloha"].sum() == 14
    assert totals.loc["split_aloha", "filter_empty"] == 8
    stages = funnel(frame).set_index("robot")
    assert stages.loc["fr3", "candidates_total"] == 15 * 6000
    assert stages.loc["fr3", "candidates_passed_filter"] == 5 * (400 + 410 + 420)
    assert stages.loc["fr3", "candidates_feasible"] == 15
    assert stages.loc["fr3", "candidates_succeeded"] == 11
    assert stages.loc["fr3", "candidates_tested"] == 15 * 3  # every fr3 episode tested 3
    # split_aloha: 3 tested in each of the 22 episodes whose filter kept candidates
    assert stages.loc["split_aloha", "candidates_tested"] == 22 * 3
    # split_aloha: 8 filter_empty episodes of 30 kept no candidate; 9 found nothing feasible.
    assert stages.loc["split_aloha", "episodes_filter_ok"] == pytest.approx(22 / 30)
    assert stages.loc["split_aloha", "episodes_feasible"] == pytest.approx(21 / 30)
    assert stages.loc["split_aloha", "episodes_success"] == pytest.approx(16 / 30)


# --------------------------------------------------------------------------------------------
# Files


def test_build_report_writes_every_file_and_a_self_contained_html(fixture_run: Path) -> None:
    paths = build_report(fixture_run)
    for path in (paths.summary_csv, paths.best_csv, paths.report_md, paths.report_html):
        assert path.is_file() and path.stat().st_size > 0
    assert set(paths.plots) == {"success", "failures", "funnel"}
    for plot in paths.plots.values():
        assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    summary = pd.read_csv(paths.summary_csv)
    assert summary["successes"].sum() == 27 and summary["n"].sum() == 45
    page = paths.report_html.read_text(encoding="utf-8")
    images = re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', page)
    assert len(images) == 3
    assert all(base64.b64decode(data)[:4] == b"\x89PNG" for data in images)
    assert 'src="plots/' not in page and "<link" not in page  # nothing external
    assert "approach_filter=downward 140, pre_grasp_offset=0.05" in page
    markdown = paths.report_md.read_text(encoding="utf-8")
    for name in ("success", "failures", "funnel"):
        assert f"(plots/{name}.png)" in markdown
    assert "| fr3 | left | cube | approach_filter=downward 120, pre_grasp_offset=0.1 | 2/5 |" in (
        markdown
    )


@pytest.mark.parametrize("axes", [1, 0])
def test_report_with_one_or_no_swept_axis(fixture_run: Path, tmp_path: Path, axes: int) -> None:
    def edit(frame: pd.DataFrame) -> pd.DataFrame:
        frame = frame.drop(columns=["param.pick.pre_grasp_offset"])
        frame = frame[frame["point_id"] != 2]
        if axes == 0:
            frame = frame.drop(columns=["param.pick.approach_filter"])
        return frame

    run = modified_run(fixture_run, tmp_path / f"axes{axes}", edit)
    paths = build_report(run)
    assert all(plot.stat().st_size > 0 for plot in paths.plots.values())
    assert pd.read_csv(paths.summary_csv)["n"].sum() == 30


def test_report_from_the_store_exports_episodes(tmp_path: Path) -> None:
    frame = pd.read_csv(FIXTURE, keep_default_na=False)
    store = ResultStore(tmp_path)
    for record in frame.to_dict("records"):
        store.append(record)
    paths = build_report(tmp_path, export=True)
    assert len(pd.read_csv(tmp_path / "episodes.csv")) == 45
    assert len(pd.read_parquet(tmp_path / "episodes.parquet")) == 45
    assert pd.read_csv(paths.summary_csv)["successes"].sum() == 27


def test_failure_messages_are_listed_most_frequent_first(fixture_run: Path) -> None:
    from harness.report import error_messages

    frame = load_episodes(fixture_run)
    empty = frame.index[frame["failure_reason"] == "filter_empty"]
    frame.loc[empty[:3], "error_message"] = "no grasp passed the filters"
    frame.loc[frame.index[frame["failure_reason"] == "dropped"][0], "error_message"] = "x" * 500
    messages = error_messages(frame)
    assert messages.loc[0, "failure_reason"] == "filter_empty"
    assert messages.loc[0, "message"] == "no grasp passed the filters"
    assert messages.loc[0, "episodes"] == 3
    assert messages.loc[0, "example"] == frame.loc[empty[0], "episode_id"]
    assert messages.loc[1, "failure_reason"] == "dropped"
    assert len(messages.loc[1, "message"]) == 200
    assert len(messages) == 2


def test_missing_run_or_episodes_names_the_path(tmp_path: Path) -> None:
    with pytest.raises(HarnessError, match="nowhere: run directory not found"):
        build_report(tmp_path / "nowhere")
    (tmp_path / "empty").mkdir()
    with pytest.raises(HarnessError, match="empty: no episodes"):
        build_report(tmp_path / "empty")


# --------------------------------------------------------------------------------------------
# Compare


def test_compare_runs_differences_and_p_values(fixture_run: Path, tmp_path: Path) -> None:
    def fix_fr3_point_1(frame: pd.DataFrame) -> pd.DataFrame:
        rows = (frame["robot"] == "fr3") & (frame["point_id"] == 1)
        frame.loc[rows, "success"] = True
        frame.loc[rows, "failure_reason"] = ""
        return frame[~((frame["arm"] == "right") & (frame["point_id"] == 2))]

    run_b = modified_run(fixture_run, tmp_path / "b", fix_fr3_point_1)
    comparison = compare_runs(fixture_run, run_b)
    assert len(comparison) == 9
    changed = comparison[(comparison["robot"] == "fr3") & (comparison["point_id"] == 1)].iloc[0]
    assert (changed["successes_a"], changed["successes_b"]) == (2, 5)
    assert changed["difference"] == pytest.approx(0.6)
    # Same seeds: paired. The 2 successes of A succeed in B too; 3 pairs succeed in B only, so
    # the exact McNemar p is P(Binomial(3, 1/2) in {0, 3}) = 2 / 8.
    assert changed["test"] == "mcnemar"
    assert (changed["pairs"], changed["only_a"], changed["only_b"]) == (5, 0, 3)
    assert changed["p_value"] == pytest.approx(0.25)
    same = comparison[(comparison["present"] == "both") & (comparison["difference"] == 0)]
    assert len(same) == 7 and (same["p_value"] == 1.0).all()
    only_a = comparison[comparison["present"] == "a only"]
    assert only_a[["robot", "arm", "point_id"]].values.tolist() == [["split_aloha", "right", 2]]
    assert only_a["p_value"].isna().all()

    def new_seeds(frame: pd.DataFrame) -> pd.DataFrame:
        frame = fix_fr3_point_1(frame)
        return frame.assign(seed=frame["seed"] + 1_000_000)

    unpaired = compare_runs(fixture_run, modified_run(fixture_run, tmp_path / "c", new_seeds))
    changed = unpaired[(unpaired["robot"] == "fr3") & (unpaired["point_id"] == 1)].iloc[0]
    assert changed["test"] == "fisher" and changed["pairs"] == 0
    assert changed["p_value"] == pytest.approx(20 / 120)  # k1 = 2 or 5 of 7 successes


def test_compare_uses_the_z_test_for_large_samples(tmp_path: Path) -> None:
    def run(name: str, successes: int) -> Path:
        directory = tmp_path / name
        store = ResultStore(directory)
        for index in range(50):
            store.append(
                {
                    "episode_id": f"e{index}",
                    "task": "t",
                    "robot": "fr3",
                    "arm": "left",
                    "object": "cube",
                    "point": "{}",
                    "success": index < successes,
                    "failure_reason": "" if index < successes else "dropped",
                }
            )
        return directory

    comparison = compare_runs(run("a", 30), run("b", 40))
    row = comparison.iloc[0]
    assert (row["rate_a"], row["rate_b"]) == (0.6, 0.8)
    assert row["test"] == "z"
    assert row["z"] == pytest.approx(2.18218, abs=1e-5)
    assert row["p_value"] == pytest.approx(0.029096, abs=1e-6)


# --------------------------------------------------------------------------------------------
# Commands


def test_report_and_compare_commands(fixture_run: Path, tmp_path: Path, capsys) -> None:
    assert cli_main(["report", str(fixture_run)]) == 0
    out = capsys.readouterr().out
    assert "best for fr3" in out and "report.html" in out
    csv_path = tmp_path / "out" / "compare.csv"
    assert cli_main(["compare", str(fixture_run), str(fixture_run), "--csv", str(csv_path)]) == 0
    written = pd.read_csv(csv_path)
    assert len(written) == 9 and (written["difference"] == 0).all()
    assert cli_main(["report", str(tmp_path / "missing")]) == 2
    assert "missing: run directory not found" in capsys.readouterr().err
    assert cli_main(["compare", str(fixture_run), str(tmp_path / "missing")]) == 2


def test_valid_rate_gap_and_objective(fixture_run: Path, tmp_path: Path) -> None:
    """Validity columns by hand: fr3 point 2 is 5/5 reference but 1/5 valid (four fingers in
    the table), point 0 is 4/5 reference and 4/5 valid. The valid objective picks point 0;
    rows without the columns (the original fixture) have no valid rate."""

    def edit(frame: pd.DataFrame) -> pd.DataFrame:
        frame["valid"] = frame["success"].astype(str) == "True"
        frame["invalid_reason"] = ["" if v else "not_run" for v in frame["valid"]]
        frame["robustness_g"] = [4.0 if v else float("nan") for v in frame["valid"]]
        fr3_2 = (frame["robot"] == "fr3") & (frame["point_id"] == 2)
        through = fr3_2 & (frame.groupby(fr3_2).cumcount() < 4)
        frame.loc[through, "valid"] = False
        frame.loc[through, "invalid_reason"] = "table_penetration"
        frame.loc[through, "robustness_g"] = 2.0
        return frame

    run = modified_run(fixture_run, tmp_path / "valid-run", edit)
    summary = summarize(load_episodes(run)).set_index(["robot", "arm", "point_id"])
    point = summary.loc[("fr3", "left", 2)]
    assert (point["successes"], point["valid"], point["n_judged"]) == (5, 1, 5)
    assert point["valid_rate"] == pytest.approx(0.2)
    assert (point["valid_ci_low"], point["valid_ci_high"]) == pytest.approx(
        WILSON[(1, 5)], abs=5e-5
    )
    assert point["gap.table_penetration"] == 4 and point["robustness.2"] == 4
    assert point["robustness.4"] == 1
    flat = summarize(load_episodes(run))
    assert best_settings(flat, "reference").set_index("robot").loc["fr3", "point_id"] == 2
    assert best_settings(flat, "valid").set_index("robot").loc["fr3", "point_id"] == 0
    assert best_settings(flat).set_index("robot").loc["fr3", "point_id"] == 0  # valid: default
    paths = build_report(run, objective="valid")
    text = paths.report_md.read_text()
    assert "Validity gap" in text and "robustness_g" in text and "valid rate" in text
    assert {"valid_rate", "valid_ci_low", "valid_ci_high"} <= set(pd.read_csv(paths.summary_csv))
    plain = summarize(load_episodes(fixture_run))
    assert plain["valid_rate"].isna().all() and (plain["n_judged"] == 0).all()


def test_report_of_a_sweep_whose_only_axis_is_the_object_mesh(
    fixture_run: Path, tmp_path: Path
) -> None:
    """object.mesh varies (one value per object) but is no setting: the best table has no such
    column, and the report must not look it up (it raised KeyError 'param.object.mesh')."""

    def edit(frame: pd.DataFrame) -> pd.DataFrame:
        frame = frame.drop(columns=["param.pick.pre_grasp_offset", "param.pick.approach_filter"])
        frame = frame[frame["point_id"] != 2].copy()
        frame["object"] = ["cube" if p == 0 else "banana" for p in frame["point_id"]]
        frame["param.object.mesh"] = frame["object"]
        frame["point"] = [json.dumps({"object.mesh": o}) for o in frame["object"]]
        return frame

    run = modified_run(fixture_run, tmp_path / "mesh-only", edit)
    paths = build_report(run)
    markdown = paths.report_md.read_text(encoding="utf-8")
    assert "| fr3 | left | banana | default |" in markdown
    assert "| fr3 | left | cube | default |" in markdown


@pytest.mark.parametrize(("rows", "labelled"), [(20, True), (50, False)])
def test_a_large_success_heatmap_is_colour_only(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, rows: int, labelled: bool
) -> None:
    """A robot's heatmap of 20 x 10 cells carries each cell's counts as text; one of 50 x 10
    (over ``MAX_LABELLED_CELLS``) is colour only (a tune's refine pass drew 4,000 unreadable
    texts into an 8 MB PNG) and says where the counts are."""
    from matplotlib.axes import Axes

    from harness.report import plots

    texts: list[str] = []
    original = Axes.text

    def counted(self: Axes, x: float, y: float, s: str, *args: object, **kwargs: object) -> object:
        texts.append(s)
        return original(self, x, y, s, *args, **kwargs)

    monkeypatch.setattr(Axes, "text", counted)
    records = [
        {
            **{"robot": "fr3", "arm": "left", "object": "cube", "point_id": i * 10 + j},
            **{"param.pick.filter_z_dir": float(90 + j), "param.pick.filter_x_dir": float(i)},
            **{"n": 10, "successes": (i + j) % 11, "n_judged": 10, "valid": (i * j) % 11},
            "fallback": 0,
        }
        for i in range(rows)
        for j in range(10)
    ]
    summary = pd.DataFrame(records)
    path = plots.plot_success(summary, tmp_path / "success.png", "valid")
    assert path.is_file()
    cells = [t for t in texts if t.startswith("valid ")]
    assert len(cells) == (rows * 10 if labelled else 0)
