"""Random inputs through ``validate`` and a one-episode run (issue 15, "What must show").

Hypothesis draws a grasp array (valid rows of the cube's file, then possibly empty, a wrong
column count, an integer dtype, a NaN, an infinity, a non-positive score or a sheared rotation)
and a task (robot, arm, ``home``, timestep, placement height, mass), sometimes wrapped in a
one-point sweep. Whatever is drawn, the outcome must be one of two: ``validate`` and the run
both refuse it with one ``error:`` line and a non-zero exit (no traceback), or ``validate``
says ``ok`` and the run exits 0 with rows of which none is ``error``.
"""

from __future__ import annotations

import contextlib
import io
import json
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from helpers import ROBOTS
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from reference_robots import FUZZ_CLEAN_ARMS

from harness import cli
from harness.robots import RobotModel
from harness.robots.facts import robot_arms

ROOT = Path(__file__).resolve().parents[1]
CUBE = ROOT / "tasks" / "objects" / "cube"
GOOD_GRASPS = np.load(CUBE / "grasps.npy", allow_pickle=False)

CORRUPTIONS = ("none", "empty", "columns", "int", "nan", "inf", "score", "shear")


@st.composite
def grasp_arrays(draw: st.DrawFn, clean: bool) -> np.ndarray:
    rows = draw(st.integers(min_value=1, max_value=200))
    start = draw(st.integers(min_value=0, max_value=len(GOOD_GRASPS) - rows))
    array = GOOD_GRASPS[start : start + rows].copy()
    corruption = "none" if clean else draw(st.sampled_from(CORRUPTIONS))
    cell = (draw(st.integers(0, rows - 1)), draw(st.integers(0, 16)))
    if corruption == "empty":
        return array[:0]
    if corruption == "columns":
        return array[:, : draw(st.sampled_from([1, 16]))]
    if corruption == "int":
        return array.astype(np.int64)
    if corruption in ("nan", "inf"):
        array[cell] = np.nan if corruption == "nan" else -np.inf
    elif corruption == "score":
        array[cell[0], 0] = draw(st.sampled_from([0.0, -1.0]))
    elif corruption == "shear":
        array[cell[0], 5] += 0.5
    return array


# Arm joint count per bundled robot (a home of another length is an error).
ROBOT_HOMES = {name: len(RobotModel.load(name).arms[robot_arms(name)[0]].joints) for name in ROBOTS}

# Arms that exist, with the direction filter their canonical task uses.
CLEAN_ARMS = FUZZ_CLEAN_ARMS


@st.composite
def task_documents(draw: st.DrawFn, clean: bool) -> dict[str, Any]:
    """A task document; ``clean`` draws only values a run accepts (the run itself still
    varies: robot, arm, grasps, timestep, placement height, mass)."""
    if clean:
        robot, arm = draw(st.sampled_from(CLEAN_ARMS))
    else:
        robot = draw(st.sampled_from([*ROBOT_HOMES, "ur5"]))
        arm = draw(st.sampled_from(["left", "right"]))
    doc: dict[str, Any] = {
        "name": "fuzz",
        "robot": robot,
        "arm": arm,
        "objects": [{"name": "cube", "mesh": str(CUBE / "cube.obj"), "grasps": "GRASPS"}],
        "physics": {"timestep": draw(st.sampled_from([0.002, 0.004] if clean else [1e-6, 1e-9]))},
        "max_episode_length": 300,
        "pick": {"filter_z_dir": ["downward", 140]},
    }
    if not clean and draw(st.booleans()):
        joints = ROBOT_HOMES.get(robot, 7) + draw(st.sampled_from([0, 0, -1, 1]))
        values = st.floats(min_value=-4.0, max_value=4.0, allow_nan=False)
        doc["home"] = draw(st.lists(values, min_size=joints, max_size=joints))
    z = draw(st.sampled_from([None, 0.0, 0.01] if clean else [None, 0.0, -0.03]))
    if z is not None:
        doc["objects"][0]["placement"] = {"pos_range": [[0.45, 0.0, z], [0.5, 0.05, z]]}
    doc["objects"][0]["mass"] = draw(st.sampled_from([0.05, 0.2] if clean else [0.05, 0.0, -1.0]))
    return doc


@st.composite
def inputs(draw: st.DrawFn) -> tuple[np.ndarray, dict[str, Any], bool]:
    """Half the examples clean (they must run), half with at least one drawn fault."""
    clean = draw(st.booleans())
    return draw(grasp_arrays(clean)), draw(task_documents(clean)), draw(st.booleans())


def _cli(args: list[str]) -> tuple[int, str]:
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        code = cli.main(args)
    return code, err.getvalue()


def _assert_clean_refusal(code: int, stderr: str) -> None:
    assert code != 0
    assert "Traceback" not in stderr
    errors = [line for line in stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, stderr


@pytest.mark.slow
@settings(
    max_examples=14,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(drawn=inputs())
def test_random_inputs_are_refused_in_one_line_or_run_without_error_rows(
    drawn: tuple[np.ndarray, dict[str, Any], bool],
) -> None:
    grasps, task, as_sweep = drawn
    with tempfile.TemporaryDirectory(prefix="fuzz-") as folder:
        base = Path(folder)
        np.save(base / "grasps.npy", grasps)
        task["objects"][0]["grasps"] = str(base / "grasps.npy")
        task_path = base / "task.yaml"
        task_path.write_text(yaml.safe_dump(task), encoding="utf-8")
        run_dir = base / "run"
        if as_sweep:
            sweep = {"name": "fuzz", "tasks": [str(task_path)], "episodes_per_point": 1}
            target = base / "sweep.yaml"
            target.write_text(yaml.safe_dump(sweep), encoding="utf-8")
            run_args = ["sweep", str(target), "--backend", "serial", "--no-progress"]
        else:
            target = task_path
            run_args = ["run", str(target), "--episodes", "1"]
        run_args += ["--out", str(run_dir), "--record", "none"]

        code, stderr = _cli(["validate", str(target)])
        run_code, run_stderr = _cli(run_args)
        event("refused" if code else "ran")
        if code != 0:
            _assert_clean_refusal(code, stderr)
            _assert_clean_refusal(run_code, run_stderr)
            assert not (run_dir / "episodes.jsonl").exists()
            return
        assert run_code == 0, run_stderr
        lines = (run_dir / "episodes.jsonl").read_text(encoding="utf-8").splitlines()
        rows = [json.loads(line) for line in lines if line.strip()]
        assert len(rows) == 1
        assert rows[0]["failure_reason"] != "error", rows[0]["error_message"]
        event(f"ran: {rows[0]['failure_reason'] or 'success'}")
