"""Small things a newcomer meets first: did-you-mean for a section key without its section,
help texts without Python symbols, ``dir(harness)`` showing the API."""

from __future__ import annotations

import pytest

import harness
from harness.cli import build_parser, main


@pytest.mark.parametrize(
    "key, hint", [("filter_z_dir", "pick.filter_z_dir"), ("mass", "object.mass")]
)
def test_set_of_a_section_key_suggests_its_dotted_name(key: str, hint: str, capsys) -> None:
    code = main(["run", "tasks/pick/fr3.yaml", "--set", f"{key}=1", "--episodes", "1"])
    assert code == 2
    err = capsys.readouterr().err
    assert f"did you mean '{hint}'?" in err and len(err.strip().splitlines()) == 1


def _help(command: str) -> str:
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    return sub.choices[command].format_help()  # type: ignore[union-attr]


def test_sweep_help_prints_the_episode_limit_not_a_python_symbol() -> None:
    text = _help("sweep")
    assert "harness.runs" not in text and "MAX_EPISODES" not in text
    assert "200,000" in " ".join(text.split())
    assert "limits.MAX_POINTS" not in text  # --max-points says its number (issue 36)
    assert "pairs (default: 2,000)" in " ".join(text.split())


def test_bench_only_help_lists_every_section() -> None:
    from harness.benchmarks.framework import SECTIONS

    text = " ".join(_help("bench").split())
    assert "sharing" in SECTIONS and all(name in text for name in SECTIONS)


def test_dir_of_the_package_shows_the_api() -> None:
    names = dir(harness)
    for name in ("load_task", "run_episode", "sweep", "load_run", "__version__"):
        assert name in names


def test_interndata_entry_without_its_data_gives_a_hint(tmp_path, capsys) -> None:
    """A fresh clone has no InternDataEngine files next to it: one line says where to get them."""
    sweep = tmp_path / "sweep.yaml"
    sweep.write_text(
        "name: x\ntasks:\n  - interndata: ../absent/franka_single_pick_banana.yaml\n"
        "episodes_per_point: 1\n",
        encoding="utf-8",
    )
    assert main(["validate", str(sweep)]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert "tasks[0].interndata" in err[0] and "InternDataEngine task file not found" in err[0]
    assert "outside this repository" in err[0] and "docs/interndata.md" in err[0]


def test_report_heatmap_axes_keep_their_own_order() -> None:
    """A tune adds the task's current setting as its last point; the heatmap axis still puts
    it in its place (single angles ascending, then bands)."""
    import pandas as pd

    from harness.report.heatmaps import _axis_values, axis_key

    values = ['["downward", 150]', '["downward", 120]', '["downward", 110, 150]',
              '["downward", 135]', '["downward", 140]']  # fmt: skip
    group = pd.DataFrame({"param.pick.approach_filter": values, "point_id": range(len(values))})
    assert _axis_values(group, "param.pick.approach_filter") == [
        '["downward", 120]', '["downward", 135]', '["downward", 140]', '["downward", 150]',
        '["downward", 110, 150]',
    ]  # fmt: skip
    assert sorted([3, 1.5, 2], key=axis_key) == [1.5, 2, 3]


def test_sweep_recording_opens_on_its_point_timeline_one_series_per_arm_and_object(
    tmp_path,
) -> None:
    """Points of two objects interleave (cube 0, 2; banana 1, 3): each gets its own series, and
    the blueprint's time panel opens on the ``point`` timeline that holds the data."""
    import pandas as pd
    from helpers import read_back
    from rerun.chunk import RrdReader

    from harness.viz.sweep_recording import record_sweep

    rows = [
        {"task": "t", "robot": "fr3", "arm": "left", "object": obj, "point_id": point,
         "n": 4, "successes": 3, "rate": 0.75, "wilson_lo": 0.3, "wilson_hi": 0.95}
        for point, obj in enumerate(["cube", "banana", "cube", "banana"])
    ]  # fmt: skip
    pd.DataFrame(rows).to_csv(tmp_path / "summary.csv", index=False)
    path = record_sweep(tmp_path)
    assert path is not None
    entities, _ = read_back(path)
    series = sorted(e for e in entities if e.startswith("/sweep/"))
    assert series == ["/sweep/fr3/left/banana", "/sweep/fr3/left/cube"]
    for entity in series:
        assert entities[entity]["Scalars:scalars"] == 2  # its own two points, nothing else
    reader = RrdReader(str(path))
    timelines = [
        chunk.to_record_batch().column("TimePanelBlueprint:timeline").to_pylist()
        for chunk in reader.stream(store=reader.blueprints()[0]).to_chunks()
        if "TimePanelBlueprint:timeline" in chunk.to_record_batch().schema.names
    ]
    assert timelines == [[["point"]]]
