"""The benchmark framework: statistics, targets, table and JSON shapes, and the CLI end to end.

No timed assertions: these tests check that numbers are summarised, judged and written
correctly, not how fast anything is.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import pytest

from harness.benchmarks import framework as bench
from harness.benchmarks import grasps as grasps_bench
from harness.benchmarks.estimate import (
    REFERENCE,
    estimate,
    left_line,
    probe_seconds,
    save_times,
)
from harness.benchmarks.framework import (
    PERCENTILES,
    WILSON_95,
    Figure,
    SectionRun,
    bench_payload,
    figure,
    format_table,
    format_target_notes,
    json_safe,
    rate_figure,
    summarize,
    time_call,
)
from harness.benchmarks.machine import (
    CpuSnapshot,
    ScalingCalibration,
    cpu_use_between,
    spin,
)
from harness.cli import main as cli_main


def _strict_json(text: str) -> object:
    """Parse JSON refusing NaN / Infinity (Python's json accepts them by default)."""

    def reject(constant: str) -> None:
        raise ValueError(f"non-standard JSON constant {constant}")

    return json.loads(text, parse_constant=reject)


# --------------------------------------------------------------------------------------------
# Statistics


def test_summarize_median_and_deciles() -> None:
    median, p10, p90 = summarize([float(v) for v in range(11, 0, -1)])  # 1..11, unordered
    assert (median, p10, p90) == (6.0, 2.0, 10.0)


def test_summarize_single_sample_and_empty() -> None:
    assert summarize([0.25]) == (0.25, 0.25, 0.25)
    with pytest.raises(ValueError):
        summarize([])


def test_figure_scales_and_drops_non_finite_samples() -> None:
    fig = figure("s", "f", [0.001, 0.002, float("nan"), 0.003], "ms", scale=1e3)
    assert fig.repetitions == 3
    assert fig.median == pytest.approx(2.0)
    assert fig.low == pytest.approx(1.2) and fig.high == pytest.approx(2.8)
    assert fig.spread == PERCENTILES

    empty = figure("s", "f", [float("nan")], "s")
    assert empty.repetitions == 0 and math.isnan(empty.median)


def test_time_call_runs_warmup_then_repetitions() -> None:
    calls = []
    samples = time_call(lambda: calls.append(1), repetitions=4, warmup=2)
    assert len(calls) == 6
    assert len(samples) == 4 and all(s >= 0.0 for s in samples)


def test_rate_figure_is_a_percentage_with_its_wilson_interval() -> None:
    fig = rate_figure("ik", "success", 18, 20)
    assert fig.unit == "%" and fig.repetitions == 20 and fig.spread == WILSON_95
    assert fig.median == pytest.approx(90.0)
    assert 60.0 < fig.low < 90.0 < fig.high < 100.0
    none = rate_figure("ik", "success", 0, 20)
    assert none.median == 0.0 and none.low == pytest.approx(0.0, abs=1e-12)
    assert 10.0 < none.high < 20.0  # 0/20: the upper bound is about 16 %


# --------------------------------------------------------------------------------------------
# Targets


def _fig(median: float, target: float | None, higher: bool = False, **kwargs: object) -> Figure:
    return Figure("s", "f", "ms", median, median, median, 5, target, higher, **kwargs)  # type: ignore[arg-type]


def test_meets_target_lower_and_higher_is_better() -> None:
    assert _fig(0.8, 1.0).meets_target is True
    assert _fig(1.0, 1.0).meets_target is True
    assert _fig(1.27, 1.0).meets_target is False
    assert _fig(1.9, 1.8, higher=True).meets_target is True
    assert _fig(1.53, 1.8, higher=True).meets_target is False
    assert _fig(5.0, None).meets_target is None
    assert _fig(float("nan"), 1.0).meets_target is False


def test_verdict_says_by_how_much_a_target_is_missed() -> None:
    assert _fig(0.5, 1.0).verdict() == "yes"
    assert _fig(1.27, 1.0).verdict() == "no (27% over)"
    assert _fig(1.53, 1.8, higher=True).verdict() == "no (15% short)"
    assert _fig(2.0, None).verdict() == ""
    assert _fig(1.27, 1.0).target_ratio == pytest.approx(1.27)


# --------------------------------------------------------------------------------------------
# Table and JSON


def _figures() -> list[Figure]:
    return [
        figure("grasps", "one file", [0.0004, 0.0005, 0.0006], "ms", scale=1e3, target=1.0),
        figure("sweeps", "scaling", [1.5], "x", target=1.8, higher_is_better=True, notes="busy"),
        rate_figure("ik", "success, reachable", 9, 10),
        figure("episodes", "plan", [float("nan")], "s"),
    ]


def test_format_table_rows_spreads_and_verdicts() -> None:
    lines = format_table(_figures()).splitlines()
    assert lines[0].startswith("| section | figure | median |")
    assert len(lines) == 2 + 4
    assert all(line.count("|") == 8 for line in lines)
    grasps_row, scaling_row, rate_row, nan_row = lines[2:]
    assert "| 0.5 ms | 0.42 – 0.58 | 3 | ≤ 1 | yes |" in grasps_row
    assert "| 1.5 x | – | 1 | ≥ 1.8 | **no (17% short)** |" in scaling_row
    assert "(CI)" in rate_row and "| 90 % |" in rate_row
    assert "| nan s |" in nan_row and "| 0 |" in nan_row


def test_format_table_for_a_terminal_keeps_comparison_signs() -> None:
    fig = figure("engines", "batches of <= 8 worlds", [1.0], "s", notes="x")
    terminal = format_table([fig])
    assert "batches of <= 8 worlds" in terminal and "&lt;" not in terminal  # printed as typed
    assert "batches of &lt;= 8 worlds" in format_table([fig], escape_html=True)  # for a page


def test_target_notes_list_missed_targets_first() -> None:
    notes = format_target_notes(_figures()).splitlines()
    assert notes == ["- sweeps / scaling: no (17% short); busy"]
    same = [_fig(0.5, 1.0, notes="7 DoF"), _fig(0.6, 1.0, notes="7 DoF")]
    assert format_target_notes(same).splitlines()[1].endswith("yes; (as above)")


def test_json_payload_is_strict_json_with_machine_and_sections() -> None:
    figures = _figures()
    run = SectionRun("grasps", figures, 1.5, [0.5, 0.4, 0.3], [0.6, 0.4, 0.3], 0.1)
    info = {"cpu_model": "test CPU", "cpus": 2, "versions": {"mujoco": "x"}}
    payload = bench_payload([run], True, info, [0.5, 0.4, 0.3], [0.7, 0.5, 0.3], 2.0)
    data = _strict_json(json.dumps(json_safe(payload), allow_nan=False))
    assert isinstance(data, dict)
    assert data["machine"]["cpu_model"] == "test CPU"
    assert data["machine"]["load_average_start"] == [0.5, 0.4, 0.3]
    assert data["machine"]["load_average_end"] == [0.7, 0.5, 0.3]
    assert data["sections"][0]["name"] == "grasps" and data["sections"][0]["figures"] == 4
    assert len(data["figures"]) == 4
    first = data["figures"][0]
    for key in ("section", "name", "unit", "median", "low", "high", "repetitions", "spread"):
        assert key in first
    assert first["meets_target"] is True
    assert data["figures"][1]["meets_target"] is False
    assert data["figures"][3]["median"] is None  # NaN written as null


# --------------------------------------------------------------------------------------------
# Machine-load helpers (arithmetic only; the calibration itself runs in the benchmark)


def test_cpu_use_between_subtracts_our_own_time() -> None:
    before = CpuSnapshot(wall_s=10.0, busy_s=100.0, steal_s=1.0, own_s=5.0)
    after = CpuSnapshot(wall_s=12.0, busy_s=103.0, steal_s=1.2, own_s=7.0)
    use = cpu_use_between(before, after)
    assert use.own_cpus == pytest.approx(1.0)
    assert use.others_cpus == pytest.approx(0.5)
    assert use.steal_cpus == pytest.approx(0.1)
    unknown = cpu_use_between(CpuSnapshot(0.0, None, None, 0.0), CpuSnapshot(1.0, None, None, 0.5))
    assert unknown.others_cpus is None and unknown.own_cpus == pytest.approx(0.5)


def test_scaling_calibration_ratio() -> None:
    calibration = ScalingCalibration(2, [1.0, 1.0, 1.2], [[1.0, 1.1], [1.0, 1.0], [1.2, 2.4]])
    assert calibration.scalings == pytest.approx([2 / 1.1, 2.0, 1.0])
    assert calibration.scaling == pytest.approx(2 / 1.1)
    assert spin(10) == sum(i * i % 7 for i in range(10))


# --------------------------------------------------------------------------------------------
# Sections and the CLI


def test_grasp_source_falls_back_to_a_default_object(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setattr(grasps_bench, "EXAMPLE", tmp_path / "absent.npy")
    path, label = grasps_bench.grasp_source()
    assert path == grasps_bench.DEFAULT_OBJECTS / "bottle" / "grasps.npy"
    assert path.is_file()
    assert "example data absent" in label


def test_grasp_source_prefers_the_example_file(examples_dir: Path) -> None:
    path, label = grasps_bench.grasp_source()
    assert path == grasps_bench.EXAMPLE and label == "example bottle_0"


def test_unknown_section_is_one_clear_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli_main(["bench", "--only", "nonsense"]) != 0
    assert "unknown bench section(s) ['nonsense']" in capsys.readouterr().err


def test_cli_quick_grasps_and_timing_write_valid_json(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``harness bench --quick --only grasps timing --json FILE`` through the CLI. The example
    grasp file is hidden so the run exercises the fallback that works without ../shared."""
    monkeypatch.setattr(grasps_bench, "EXAMPLE", tmp_path / "absent.npy")
    monkeypatch.setenv("PICK_HARNESS_CACHE", str(tmp_path / "cache"))
    out = tmp_path / "reports" / "bench.json"
    code = cli_main(["bench", "--quick", "--only", "grasps", "timing", "--json", str(out)])
    assert code == 0
    # The estimate before the run and the time left after each section come from measurements;
    # this run's section times are kept for the next estimate on this machine.
    captured = capsys.readouterr()
    err = captured.err
    assert "bench: about " in err and "expected (a quick run on 2 vCPUs at commit" in err
    assert re.search(r"bench: grasps \d+ figures in [\d.]+ s; about \d+ s left", err)
    times = json.loads((tmp_path / "cache" / "bench-times.json").read_text(encoding="utf-8"))
    assert set(times["quick"]["sections"]) >= {"grasps", "timing"}
    assert times["quick"]["probe_s"] > 0
    data = _strict_json(out.read_text(encoding="utf-8"))
    assert isinstance(data, dict)
    assert data["quick"] is True
    assert [s["name"] for s in data["sections"]] == ["grasps", "timing"]
    assert all(s["error"] is None for s in data["sections"])
    machine = data["machine"]
    for key in ("cpu_model", "cpus", "python", "versions", "load_average_start"):
        assert key in machine
    assert machine["versions"]["mujoco"]
    figures = data["figures"]
    assert {f["section"] for f in figures} == {"grasps", "timing"}
    for fig in figures:
        assert fig["repetitions"] > 0
        assert fig["low"] <= fig["median"] <= fig["high"]
    by_name = {f["name"]: f for f in figures}
    one_file = by_name["post-process + filter + order, one file (6000 poses)"]
    assert "example data absent" in one_file["notes"]
    assert one_file["target"] == 1.0 and isinstance(one_file["meets_target"], bool)
    million = by_name["post-process + filter + order, 1,000,000 poses"]
    assert million["target"] == 100.0
    assert any(name.startswith("Ruckig") for name in by_name)
    assert any(name.startswith("TOPP-RA") for name in by_name)
    printed = captured.out
    assert "| section | figure |" in printed and str(out) in printed


def test_estimate_scales_this_machines_last_run_by_the_probe(tmp_path: Path) -> None:
    path = tmp_path / "bench-times.json"
    save_times(True, 0.1, {"grasps": 10.0, "sweeps": 100.0}, path)
    save_times(True, 0.2, {"grasps": 30.0}, path)  # a later run of one section, twice as slow
    stored = json.loads(path.read_text(encoding="utf-8"))["quick"]
    assert stored["probe_s"] == 0.2
    assert stored["sections"] == {"grasps": 30.0, "sweeps": pytest.approx(200.0)}
    expected = estimate(True, 0.1, path)  # the machine is twice as fast now
    assert expected.sections == {"grasps": pytest.approx(15.0), "sweeps": pytest.approx(100.0)}
    assert expected.total(["grasps", "sweeps"]) == pytest.approx(115.0)
    line = expected.line(["grasps", "sweeps"])
    assert line.startswith("bench: about 115 s expected (this machine's last quick run, ")
    assert "x0.50" in line
    assert "no measured time for engines" in expected.line(["grasps", "engines"])
    # Half way, the finished section took twice its estimate: the rest is doubled too.
    assert left_line(expected, {"grasps": 30.0}, ["sweeps"]) == "about 3.3 min left"
    assert left_line(expected, {"grasps": 30.0}, []) is None
    assert left_line(expected, {"grasps": 30.0}, ["engines"]) is None


def test_estimate_without_a_run_here_uses_the_reference_run(tmp_path: Path) -> None:
    reference = REFERENCE["quick"]
    expected = estimate(True, reference["probe_s"], tmp_path / "none.json")
    assert expected.sections == pytest.approx(reference["sections"])
    assert f"at commit {reference['commit']}" in expected.source
    assert set(reference["sections"]) == set(bench.SECTIONS)  # every default section measured
    assert (
        estimate(False, 0.1, tmp_path / "none.json")
        .line(["grasps"])
        .startswith("bench: no measured time for grasps")
    )
    assert 0 < probe_seconds(rounds=1) < 10


def test_sections_are_modules_with_run() -> None:
    import importlib

    for name in bench.SECTIONS:
        module = importlib.import_module(f"harness.benchmarks.{name}")
        assert callable(module.run), name
