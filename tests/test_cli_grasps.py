"""``harness grasps inspect``: JSON numbers, text table, plot, and error exits."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from helpers import AVAILABLE_ROBOTS_TEXT

from harness.cli import main

BOTTLE = "objects/recyclable_garbage/bottle_0/Aligned_grasp_sparse.npy"
FR3_CANONICAL = ["--filter-x", "forward", "90", "--filter-z", "downward", "140"]


@pytest.fixture
def bottle(examples_dir: Path) -> Path:
    return examples_dir / BOTTLE


def _inspect_json(capsys: pytest.CaptureFixture[str], *argv: str) -> dict:
    assert main(["grasps", "inspect", *argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def _reference_top(scores: np.ndarray, passing: list[int]) -> list[int]:
    """The reference's (score, index) tuple sort, first 20."""
    return [i for _, i in sorted((float(scores[i]), i) for i in passing)[:20]]


def test_inspect_json_numbers(bottle: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = _inspect_json(capsys, str(bottle), "--robot", "fr3", *FR3_CANONICAL)
    assert out["total"] == 6000 and out["grasps"] == 3000
    assert out["passed"] == 430
    # At the identity pose 7 grasps have -g_z exactly perpendicular to base X: "forward 90"
    # rejects both of their poses (cos 90 = 6.1e-17), so 2993 rather than 3000 pass it.
    assert out["per_filter"] == {"filter_x_dir": 2993, "filter_z_dir": 860}
    assert len(out["passing_indices"]) == 430
    scores = np.tile(np.load(bottle)[:, 0], 2)
    assert out["top_candidates"] == _reference_top(scores, out["passing_indices"])
    assert out["outcome"] == "ok" and len(out["candidates"]) == 20
    assert set(out["candidates"]) <= set(out["top_candidates"])
    assert out["filters"] == {
        "filter_x_dir": ["forward", 90.0],
        "filter_z_dir": ["downward", 140.0],
    }


def test_inspect_neutral_filters_and_object_pose(
    bottle: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pose = ["--object-pose", "0.5", "0.1", "0.02", "0.8", "0", "0", "0.6"]  # yaw ~74 degrees
    fr3 = _inspect_json(capsys, str(bottle), "--robot", "fr3", *FR3_CANONICAL, *pose)
    lift2 = _inspect_json(
        capsys,
        str(bottle),
        "--robot",
        "lift2",
        "--approach",
        "downward",
        "140",
        "--facing",
        "forward",
        "90",
        *pose,
    )
    assert fr3["passed"] == lift2["passed"] == 430
    assert fr3["passing_indices"] == lift2["passing_indices"]
    assert fr3["candidates"] == lift2["candidates"]  # same seed, same draws
    assert lift2["filter_sources"] == {
        "filter_x_dir": "approach_filter",
        "filter_z_dir": "facing_filter",
    }
    assert lift2["object_pose"] == pytest.approx([0.5, 0.1, 0.02, 0.8, 0.0, 0.0, 0.6])


def test_inspect_fallback_and_strict(bottle: Path, capsys: pytest.CaptureFixture[str]) -> None:
    reversed_band = ["--filter-z", "downward", "140", "110"]
    out = _inspect_json(capsys, str(bottle), "--robot", "split_aloha", *reversed_band)
    assert out["passed"] == 0 and out["outcome"] == "fallback"
    assert out["top_candidates"] == list(range(20)) == out["candidates"]
    argv = ["grasps", "inspect", str(bottle), "--robot", "fr3", *reversed_band]
    assert main([*argv, "--semantics", "strict"]) == 2
    err = capsys.readouterr().err
    assert "filter_z_dir" in err and "can never pass" in err and "smaller angle first" in err
    strict = _inspect_json(
        capsys, str(bottle), "--robot", "fr3", *FR3_CANONICAL, "--semantics", "strict"
    )
    assert strict["candidates"] == strict["top_candidates"]  # unique, in (score, index) order
    assert len(set(strict["candidates"])) == 20


def test_inspect_text_table(bottle: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["grasps", "inspect", str(bottle), "--robot", "fr3", *FR3_CANONICAL]) == 0
    text = capsys.readouterr().out
    lines = text.splitlines()
    row = next(line for line in lines if line.strip().startswith("filter_z_dir"))
    assert row.split()[-3:] == ["860", "6000", "14.3%"]
    combined = next(line for line in lines if line.strip().startswith("combined"))
    assert combined.split()[-3:] == ["430", "6000", "7.2%"]
    assert "top candidates (deterministic, before any draw):" in text
    assert "candidate order (20 weighted draws with replacement, sorted by score):" in text
    assert "outcome     ok" in text


def test_inspect_plot_writes_png(
    bottle: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    png = tmp_path / "plots" / "directions.png"
    argv = ["grasps", "inspect", str(bottle), "--robot", "lift2", "--plot", str(png)]
    assert main([*argv, "--approach", "downward", "140", "--facing", "forward", "90"]) == 0
    assert f"wrote {png}" in capsys.readouterr().out
    data = png.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20_000


def test_inspect_errors(bottle: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["grasps", "inspect", str(bottle), "--robot", "no_such_robot"]) == 2
    assert "no_such_robot" in capsys.readouterr().err
    assert main(["grasps", "inspect", str(bottle), "--robot", "fr3", "--arm", "right"]) == 2
    assert "no right arm" in capsys.readouterr().err
    bad = tmp_path / "bad.npy"
    np.save(bad, np.zeros((4, 16), np.float32))
    assert main(["grasps", "inspect", str(bad), "--robot", "fr3"]) == 2
    err = capsys.readouterr().err
    assert str(bad) in err and "N x 17" in err
    assert (
        main(["grasps", "inspect", str(bottle), "--robot", "fr3", "--filter-x", "sideways", "9"])
        == 2
    )
    assert "unknown direction 'sideways'" in capsys.readouterr().err
    assert (
        main(["grasps", "inspect", str(bottle), "--robot", "fr3", "--filter-x", "forward", "a"])
        == 2
    )
    assert "--filter-x" in capsys.readouterr().err


def test_robot_convention_comes_from_robot_yaml() -> None:
    from harness.commands.grasps import robot_convention
    from harness.errors import HarnessError
    from harness.robots.facts import reference_convention

    convention = robot_convention("lift2", "right")
    assert convention.ee_axis == reference_convention("lift2").ee_axis == "x"
    with pytest.raises(HarnessError, match=f"available robots: {AVAILABLE_ROBOTS_TEXT}"):
        robot_convention("ur5", "left")
    with pytest.raises(HarnessError, match="no right arm"):
        robot_convention("fr3", "right")
