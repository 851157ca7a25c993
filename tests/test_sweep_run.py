"""Sweeps end to end on real episodes: files and row counts, resume, crash recovery, Ray, Rerun."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import faults
import pandas as pd
import pytest
import yaml

from harness.config import load_sweep
from harness.report.finish import finish_run
from harness.runs.expansion import expand
from harness.runs.sweep import SweepOutcome, run_sweep

ROOT = Path(__file__).resolve().parents[1]

# Columns that must be identical between two runs of the same episodes (everything except
# timings, memory and paths).
DETERMINISTIC = [
    "episode_id",
    "task",
    "robot",
    "arm",
    "object",
    "seed",
    "point_id",
    "success",
    "failure_reason",
    "n_total",
    "n_passed_filter",
    "n_feasible",
    "chosen_index",
    "chosen_score",
    "post_grasp_offset",
    "lift_height_m",
    "sim_steps",
]


def write_sweep(tmp_path: Path, episodes: int = 2, record: str = "failures") -> Path:
    sweep = {
        "name": "e2e",
        "tasks": [str(ROOT / "tasks" / "pick" / "fr3.yaml")],
        "axes": {
            # 140: canonical; a reversed band never passes -> the reference fallback list.
            "pick.approach_filter": [["downward", 140], ["downward", 160, 120]],
        },
        "episodes_per_point": episodes,
        "seed": 5,
        "record": record,
    }
    path = tmp_path / "sweep.yaml"
    path.write_text(yaml.safe_dump(sweep), encoding="utf-8")
    return path


def rows(run_dir: Path) -> pd.DataFrame:
    frame = pd.read_csv(run_dir / "episodes.csv")
    return frame.sort_values("episode_id").reset_index(drop=True)


@pytest.fixture(scope="module")
def clean_rows(tmp_path_factory: pytest.TempPathFactory) -> pd.DataFrame:
    """The rows of ``write_sweep(episodes=2)`` run once by a process pool of two workers, with no
    fault injected: the uninterrupted, crash-free reference the resume, retry and Ray tests
    compare their rows with (it was run by each of them)."""
    tmp = tmp_path_factory.mktemp("clean")
    outcome = run_sweep(write_sweep(tmp, episodes=2), out=tmp / "run", workers=2, progress=False)
    assert outcome.stats.finished == 4 and outcome.stats.crashed == 0
    arrivals = outcome.stats.arrivals  # each row's arrival, for the run's pace
    assert len(arrivals) == 4 and arrivals == sorted(arrivals) and arrivals[0] > 0
    return rows(outcome.run_dir)


@pytest.fixture(scope="module")
def crashed_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[SweepOutcome, str]:
    """``write_sweep(episodes=2)`` by two workers, the second episode's worker segfaulting on
    every attempt: the outcome and the victim's episode id (read by the segfault test; the
    retry test resumes a copy of its folder)."""
    tmp = tmp_path_factory.mktemp("crashed")
    sweep_path = write_sweep(tmp, episodes=2)
    victim = expand(load_sweep(sweep_path), sweep_path)[1].episode_id
    assert victim is not None
    with pytest.MonkeyPatch.context() as patch:
        faults.install(patch, segfault=(victim,))
        outcome = run_sweep(sweep_path, out=tmp / "run", workers=2, progress=False)
    return outcome, victim


@pytest.mark.slow
def test_process_pool_sweep_writes_every_file(tmp_path: Path):
    sweep_path = write_sweep(tmp_path, episodes=3)
    outcome = run_sweep(sweep_path, out=tmp_path / "run", workers=2, progress=False)
    run_dir = outcome.run_dir
    finish_run(run_dir)  # the command layer's step after a run: report + overview recording
    assert outcome.stats.finished == 6 and outcome.stats.crashed == 0
    for name in (
        "sweep.yaml",
        "episodes.csv",
        "episodes.parquet",
        "summary.csv",
        "report.md",
        "report.html",
        "recording.rrd",
    ):
        assert (run_dir / name).is_file(), name
    episodes = rows(run_dir)
    assert len(episodes) == 6 and episodes["episode_id"].is_unique
    assert len(pd.read_parquet(run_dir / "episodes.parquet")) == 6
    summary = pd.read_csv(run_dir / "summary.csv")
    assert len(summary) == 2 and summary["n"].tolist() == [3, 3]
    assert summary["successes"].sum() == episodes["success"].sum()
    # The canonical point succeeds on the cube; the reversed band has nothing passing.
    canonical = episodes[~episodes["point"].str.contains("160")]
    upward = episodes[episodes["point"].str.contains("160")]
    assert canonical["success"].sum() >= 2
    assert (upward["n_passed_filter"] == 0).all()
    assert (upward["filter_outcome"] == "fallback").all()
    # The stored sweep is self-contained: it reloads and expands to the same episodes.
    stored = load_sweep(run_dir / "sweep.yaml")
    assert {e.episode_id for e in expand(stored, run_dir / "sweep.yaml")} == set(
        episodes["episode_id"]
    )


@pytest.mark.slow
def test_interrupted_then_resumed_equals_uninterrupted(tmp_path: Path, clean_rows: pd.DataFrame):
    sweep_path = write_sweep(tmp_path, episodes=2)
    part = run_sweep(sweep_path, out=tmp_path / "part", backend="serial", progress=False, limit=1)
    assert part.stats.finished == 1
    resumed = run_sweep(resume_dir=tmp_path / "part", workers=2, progress=False)
    assert resumed.skipped_existing == 1 and resumed.stats.finished == 3
    a, b = clean_rows, rows(resumed.run_dir)
    assert len(b) == 4 and b["episode_id"].is_unique  # nothing lost, nothing twice
    pd.testing.assert_frame_equal(a[DETERMINISTIC], b[DETERMINISTIC])
    # Resuming a complete run runs nothing.
    again = run_sweep(resume_dir=tmp_path / "part", progress=False)
    assert again.stats.finished == 0 and len(rows(again.run_dir)) == 4


@pytest.mark.slow
def test_segfaulting_worker_becomes_an_error_row(crashed_run: tuple[SweepOutcome, str]):
    outcome, victim = crashed_run
    # Retried once (CRASH_RETRIES), crashed again: one error row, nothing lost or doubled.
    assert outcome.stats.crashed == 1 and outcome.stats.finished == 4
    assert outcome.stats.retried == 1
    frame = rows(outcome.run_dir).set_index("episode_id")
    assert frame.loc[victim, "failure_reason"] == "error"
    assert "signal 11" in frame.loc[victim, "error_message"]
    assert "(2 attempts)" in frame.loc[victim, "error_message"]
    others = frame.drop(index=victim)
    assert (others["failure_reason"] != "error").all()
    assert len(frame) == 4


@pytest.mark.slow
def test_a_one_off_worker_crash_is_retried_not_an_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, clean_rows: pd.DataFrame
):
    """Issue 15 finding 6: a killed worker's episode was stored as a failed pick."""
    sweep_path = write_sweep(tmp_path, episodes=2)
    episodes = expand(load_sweep(sweep_path), sweep_path)
    victim = episodes[1].episode_id
    assert victim is not None
    markers = tmp_path / "markers"
    markers.mkdir()
    faults.install(monkeypatch, segfault=(victim,), once_dir=markers)
    outcome = run_sweep(sweep_path, out=tmp_path / "run", workers=2, progress=False)
    assert (markers / victim).exists()  # it did crash once
    assert outcome.stats.retried == 1 and outcome.stats.crashed == 0
    frame = rows(outcome.run_dir).set_index("episode_id")
    assert len(frame) == 4 and (frame["failure_reason"] != "error").all()
    pd.testing.assert_frame_equal(rows(outcome.run_dir)[DETERMINISTIC], clean_rows[DETERMINISTIC])


@pytest.mark.slow
def test_ray_backend_gives_the_same_rows_as_the_process_pool(
    tmp_path: Path, clean_rows: pd.DataFrame
):
    pytest.importorskip("ray")
    sweep_path = write_sweep(tmp_path, episodes=2)
    ray_run = run_sweep(sweep_path, out=tmp_path / "ray", backend="ray", workers=2, progress=False)
    pd.testing.assert_frame_equal(clean_rows[DETERMINISTIC], rows(ray_run.run_dir)[DETERMINISTIC])


@pytest.mark.slow
def test_recordings_read_back_with_rerun(tmp_path: Path):
    from rerun.chunk import RrdReader

    sweep_path = write_sweep(tmp_path, episodes=1, record="all")
    outcome = run_sweep(sweep_path, out=tmp_path / "run", backend="serial", progress=False)
    episodes = rows(outcome.run_dir)
    assert episodes["recording"].notna().all()
    recorded = outcome.run_dir / episodes.loc[0, "recording"]
    chunks = RrdReader(str(recorded)).stream().to_chunks()
    paths = {chunk.entity_path for chunk in chunks}
    for expected in (
        "/world/plan/tcp",
        "/world/executed/tcp",
        "/plots/object_z",
        "/plots/finger_force",
        "/plots/gripper_width",
        "/plots/joints",
        "/events",
        "/verdict",
    ):
        assert expected in paths, expected
    assert {"/world/candidates/rejected", "/world/candidates/chosen"} <= paths
    assert sum(p.startswith("/world/bodies/") for p in paths) > 10
    # The object-height series is on the sim_time timeline and spans the episode.
    z_chunks = [c for c in chunks if c.entity_path == "/plots/object_z"]
    times, values = [], []
    for chunk in z_chunks:
        batch = chunk.to_record_batch()
        if "sim_time" in batch.schema.names:
            times += batch.column("sim_time").to_pylist()
            values += [v[0] for v in batch.column("Scalars:scalars").to_pylist()]
    assert len(times) > 100
    if episodes.loc[0, "success"]:
        assert max(values) - values[0] > 0.02  # lifted
        # The validity phase: its slip series and the tug arrows.
        assert {"/plots/validity_slip", "/world/validity/tug"} <= paths
    finish_run(outcome.run_dir)  # the command layer writes the overview recording after a run
    overview = RrdReader(str(outcome.run_dir / "recording.rrd")).stream().to_chunks()
    overview_paths = {chunk.entity_path for chunk in overview}
    assert "/summary" in overview_paths and "/episodes" in overview_paths
    assert any(p.startswith("/sweep/") for p in overview_paths)
    points = json.loads(episodes.loc[0, "point"])
    assert "pick.approach_filter" in points


@pytest.mark.slow
def test_ctrl_c_keeps_finished_episodes_and_resume_completes(tmp_path: Path):
    """A real SIGINT to the whole process group (as Ctrl-C in a terminal), then --resume."""
    import os
    import signal
    import subprocess
    import sys
    import time

    # 2 points x 20 seeds: the second point of each seed is answered from the shared candidate
    # cache in milliseconds, so a short sweep could finish before the signal lands.
    sweep_path = write_sweep(tmp_path, episodes=20)
    run_dir = tmp_path / "run"
    harness = [sys.executable, "-m", "harness.cli", "sweep"]
    process = subprocess.Popen(
        [*harness, str(sweep_path), "--out", str(run_dir), "--workers", "2", "--no-progress"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        # As from a terminal: a shell starts background jobs with SIGINT ignored, and a child
        # inherits that (CI scripts run so), which would make the harness deaf to Ctrl-C.
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    store = run_dir / "episodes.jsonl"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and process.poll() is None:
        if store.is_file() and len(store.read_text().splitlines()) >= 3:
            break
        time.sleep(0.05)
    assert process.poll() is None, process.communicate()
    os.killpg(process.pid, signal.SIGINT)
    out, err = process.communicate(timeout=120)
    assert process.returncode == 130, err
    assert "interrupted" in out and "--resume" in out
    assert "Traceback" not in err
    kept = rows(run_dir)
    assert 3 <= len(kept) < 40 and kept["episode_id"].is_unique
    assert (kept["failure_reason"] != "error").all()  # no worker "crashed"

    resumed = subprocess.run(
        [*harness, "--resume", str(run_dir), "--no-progress"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert resumed.returncode == 0, resumed.stderr
    full = run_sweep(sweep_path, out=tmp_path / "full", workers=2, progress=False)
    pd.testing.assert_frame_equal(rows(full.run_dir)[DETERMINISTIC], rows(run_dir)[DETERMINISTIC])


@pytest.mark.slow
def test_resume_with_retry_errors_reruns_only_the_error_rows(
    tmp_path: Path, crashed_run: tuple[SweepOutcome, str]
):
    """Issue 15 finding 6: ``--resume`` never retried ``error`` rows. (A copy of the crashed
    run's folder is resumed, without the fault: the segfault test reads the original.)"""
    import shutil

    first, victim = crashed_run
    assert first.stats.crashed == 1
    run_dir = tmp_path / "run"
    shutil.copytree(first.run_dir, run_dir)
    assert rows(run_dir).set_index("episode_id").loc[victim, "failure_reason"] == "error"
    plain = run_sweep(resume_dir=run_dir, workers=2, progress=False)
    assert plain.stats.finished == 0  # an error row counts as done without the flag
    retried = run_sweep(resume_dir=run_dir, workers=2, progress=False, retry_errors=True)
    assert retried.stats.finished == 1 and retried.skipped_existing == 3
    frame = rows(run_dir).set_index("episode_id")
    assert len(frame) == 4 and (frame["failure_reason"] != "error").all()


def test_a_worker_makes_no_trace_where_no_recording_can_be_wanted(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Under ``--record none`` (and no sampled recording) the worker's episode makes no viewers'
    trace; its row is the one a worker that may record it writes."""
    import harness.episode as episode_module
    from harness.config import load_task
    from harness.episode import EpisodeSpec
    from harness.runs import worker

    real = episode_module.run_episode
    traces: list[bool] = []

    def run_episode(spec: EpisodeSpec, *args: Any, **kwargs: Any) -> Any:
        result = real(spec, *args, **kwargs)
        traces.append(result.trace is not None)
        return result

    monkeypatch.setattr(episode_module, "run_episode", run_episode)
    spec = EpisodeSpec(task=load_task(ROOT / "tasks" / "pick" / "fr3.yaml"), seed=3)
    policies = ("none", "failures")
    rows = [worker.execute(spec, str(tmp_path), policy, share=False) for policy in policies]
    assert traces == [False, True]
    varying = {"wall_time_s", "ik_time_s", "plan_time_s", "worker_peak_rss_mb"}
    assert set(rows[0]) == set(rows[1])
    for key in set(rows[0]) - varying:
        a, b = rows[0][key], rows[1][key]
        assert a == b or (a != a and b != b), key
