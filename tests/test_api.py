"""The Python API (docs/python.md): the documented example runs as a plain script (no main
guard, process-pool workers), and the functions return what the CLI writes."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import harness

ROOT = Path(__file__).resolve().parents[1]


def test_api_is_exported_lazily() -> None:
    assert set(harness.__all__) >= {"load_task", "run_episode", "sweep", "load_run"}
    assert callable(harness.run_episode) and callable(harness.sweep)
    with pytest.raises(AttributeError):
        _ = harness.no_such_function  # type: ignore[attr-defined]


def test_run_episode_from_a_path_matches_the_spec_path() -> None:
    """``harness.run_episode(path, seed)`` is the episode the sweep would run for that seed."""
    from harness.episode import EpisodeSpec
    from harness.episode import run_episode as run_spec

    direct = harness.run_episode(ROOT / "tasks" / "pick" / "fr3.yaml", seed=7)
    task = harness.load_task(ROOT / "tasks" / "pick" / "fr3.yaml")
    via_spec = run_spec(EpisodeSpec(task=task, seed=7))
    for column in ("success", "failure_reason", "chosen_index", "lift_height_m", "sim_steps"):
        assert direct.row[column] == via_spec.row[column], column


@pytest.mark.slow
def test_python_doc_example_runs_as_a_script(tmp_path: Path) -> None:
    text = (ROOT / "docs" / "python.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert len(blocks) == 1
    script = tmp_path / "example.py"
    script.write_text(blocks[0], encoding="utf-8")  # no main guard, as a user would write it
    workdir = tmp_path / "repo"
    workdir.mkdir()
    (workdir / "tasks").symlink_to(ROOT / "tasks")
    result = subprocess.run(
        [sys.executable, str(script)],
        cwd=workdir,
        capture_output=True,
        text=True,
        check=False,
        timeout=600,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    assert result.returncode == 0, result.stderr[-2000:]
    assert "episode: " in result.stdout
    assert (workdir / "reports" / "api-example" / "episodes.csv").is_file()
    # Run twice in a row, as a user re-running a notebook does: it continues the same run.
    again = subprocess.run(
        [sys.executable, str(script)],
        cwd=workdir,
        capture_output=True,
        text=True,
        check=False,
        timeout=600,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    assert again.returncode == 0, again.stderr[-2000:]
    assert again.stdout.splitlines()[0] == result.stdout.splitlines()[0]  # the same episode


def test_sweep_into_a_used_folder_says_which_flag_to_pass(tmp_path: Path) -> None:
    from harness.errors import HarnessError

    config = {"name": "x", "tasks": [str(ROOT / "tasks" / "pick" / "fr3.yaml")]}
    with pytest.raises(HarnessError, match="not both"):
        harness.sweep(config, out=tmp_path, resume=True, overwrite=True)
    with pytest.raises(HarnessError, match="needs out="):
        harness.sweep(config, resume=True)
    (tmp_path / "sweep.yaml").write_text("name: x\n", encoding="utf-8")
    with pytest.raises(HarnessError, match="already holds a run: pass resume=True"):
        harness.sweep(config, out=tmp_path)


@pytest.mark.slow
def test_sweep_into_a_used_folder_resumes_or_overwrites(tmp_path: Path) -> None:
    from harness.errors import HarnessError

    out = tmp_path / "run"
    config = {
        "name": "api-twice",
        "tasks": [str(ROOT / "tasks" / "pick" / "fr3.yaml")],
        "episodes_per_point": 1,
        "record": "none",
    }
    first = harness.sweep(config, out=out, backend="serial")
    assert len(first) == 1
    with pytest.raises(HarnessError, match=r"pass resume=True .* or overwrite=True"):
        harness.sweep(config, out=out, backend="serial")
    before = (out / "episodes.jsonl").read_text(encoding="utf-8")
    again = harness.sweep(config, out=out, backend="serial", resume=True)
    assert again["episode_id"].tolist() == first["episode_id"].tolist()
    assert (out / "episodes.jsonl").read_text(encoding="utf-8") == before  # nothing re-run
    with pytest.raises(HarnessError, match="holds a run of another sweep"):
        harness.sweep({**config, "seed": 5}, out=out, backend="serial", resume=True)
    (out / "marker").write_text("old run", encoding="utf-8")
    fresh = harness.sweep({**config, "seed": 5}, out=out, backend="serial", overwrite=True)
    assert not (out / "marker").exists() and len(fresh) == 1
    assert fresh["seed"].tolist() != first["seed"].tolist()
