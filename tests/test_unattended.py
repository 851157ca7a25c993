"""Unattended sweeps (issue 15): recordings that cannot hang or be half-written, a full disk that
stops a run with one line, episode limits that end as ``timeout``, deep validation of what a run
loads, ``error`` rows out of every rate and in the exit code, objects leaving the scene as
``sim_unstable``, and MuJoCo's log inside the run directory."""

from __future__ import annotations

import errno
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import faults
import mujoco
import numpy as np
import pandas as pd
import pytest
import yaml

from harness import cli
from harness.config import load_task
from harness.episode import EpisodeSpec
from harness.errors import EpisodeTimeoutError, InputFileError
from harness.files import bounded, is_disk_full, write_atomic
from harness.runs.preflight import check_task
from harness.runs.worker import execute
from harness.sim.budget import episode_budget

ROOT = Path(__file__).resolve().parents[1]
FR3 = ROOT / "tasks" / "pick" / "fr3.yaml"
CUBE = ROOT / "tasks" / "objects" / "cube"


def harness_cli(*args: str, env: dict[str, str] | None = None, timeout: float = 180):
    return subprocess.run(
        [sys.executable, "-m", "harness.cli", *args],
        capture_output=True,
        text=True,
        check=False,
        env={**os.environ, "PYTHONPATH": str(ROOT), **(env or {})},
        timeout=timeout,
    )


def jsonl_rows(run_dir: Path) -> list[dict]:
    lines = (run_dir / "episodes.jsonl").read_text(encoding="utf-8").splitlines()
    return [json.loads(line) for line in lines if line.strip()]


def task_file(tmp_path: Path, **changes: object) -> Path:
    """The canonical FR3 task with top-level keys changed (paths made absolute)."""
    data = yaml.safe_load(FR3.read_text(encoding="utf-8"))
    data["objects"][0]["mesh"] = str(CUBE / "cube.obj")
    data["objects"][0]["mass"] = 0.05
    data.update(changes)
    path = tmp_path / "task.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return path


# -- recordings and full disks (finding 2) --------------------------------------------------------


def test_atomic_write_on_a_full_disk_leaves_the_old_file_and_no_temp(tmp_path, monkeypatch):
    target = tmp_path / "report.html"
    target.write_text("old report", encoding="utf-8")
    with pytest.MonkeyPatch.context() as patch:
        faults.disk_full(patch, "report.html")
        with pytest.raises(OSError) as caught:
            write_atomic(target, "<html>" + "x" * 10_000)
    assert is_disk_full(caught.value)
    assert target.read_text(encoding="utf-8") == "old report"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.html"]
    write_atomic(target, "new report")
    assert target.read_text(encoding="utf-8") == "new report"


def test_a_hung_write_is_abandoned_within_its_bound() -> None:
    start = time.perf_counter()
    with pytest.raises(TimeoutError, match=r"did not finish within 0\.2 s"):
        bounded(lambda: time.sleep(5), 0.2, "a stuck disconnect")
    assert time.perf_counter() - start < 2.0


def test_recording_on_a_full_disk_stops_the_run_with_one_line(
    tmp_path, monkeypatch, capsys
) -> None:
    """Finding 2 (simulated ENOSPC): no hang, the row is kept with ``recording_error``, no
    partial ``.rrd`` or temp file is left, one line and a non-zero exit."""
    run_dir = tmp_path / "run"
    faults.disk_full(monkeypatch, ".rrd")
    args = ["run", str(FR3), "--episodes", "3", "--record", "all", "--out", str(run_dir)]
    assert cli.main(args) == 2
    stderr = capsys.readouterr().err
    errors = [line for line in stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and "disk full under" in errors[0], stderr
    assert f"harness sweep --resume {run_dir}" in errors[0]
    rows = jsonl_rows(run_dir)
    assert len(rows) == 1  # the run stopped at the first full-disk write
    assert rows[0]["recording_error"].startswith("disk full: OSError")
    assert not rows[0].get("recording")
    assert not list((run_dir / "episodes").glob("*")), "a partial recording was left"


def _mount_tmpfs(path: Path, size: str) -> bool:
    path.mkdir()
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)],
        capture_output=True,
        check=False,
    )
    return done.returncode == 0


@pytest.mark.slow
@pytest.mark.skipif(os.geteuid() != 0, reason="mounting a small tmpfs needs root")
def test_a_really_full_tmpfs_stops_the_run_and_keeps_every_finished_row(tmp_path: Path) -> None:
    """Finding 2 on a real 640 KiB file system: an episode recording is ~300 KB."""
    mount = tmp_path / "small"
    if not _mount_tmpfs(mount, "640k"):
        pytest.skip("mount -t tmpfs is not permitted here")
    try:
        run_dir = mount / "run"
        result = harness_cli(
            "run", str(FR3), "--episodes", "4", "--record", "all", "--out", str(run_dir),
        )  # fmt: skip
        assert result.returncode == 2, result.stderr
        assert "disk full under" in result.stderr and "Traceback" not in result.stderr
        rows = jsonl_rows(run_dir)
        assert 1 <= len(rows) < 4
        assert len({row["episode_id"] for row in rows}) == len(rows)  # none doubled
        for row in rows:  # a recording is whole and loadable, or absent with its reason
            if row.get("recording"):
                data = (run_dir / row["recording"]).read_bytes()
                assert data.startswith(b"RRF") and len(data) > 10_000
            else:
                assert row["recording_error"].startswith("disk full:")
        on_disk = sorted(p.name for p in (run_dir / "episodes").iterdir())
        assert on_disk == sorted(Path(r["recording"]).name for r in rows if r.get("recording"))
    finally:
        subprocess.run(["umount", str(mount)], check=False)


# -- episode limits (finding 3) -------------------------------------------------------------------


def _spec(tmp_path: Path, **task_changes: object) -> EpisodeSpec:
    task = load_task(task_file(tmp_path, **task_changes))
    return EpisodeSpec(task=task, seed=3, episode_id="limits-e0")


def test_a_simulated_step_budget_ends_the_episode_as_timeout(tmp_path: Path) -> None:
    spec = _spec(tmp_path, limits={"sim_steps": 100})
    row = execute(spec, str(tmp_path / "run"), "none")
    assert row["failure_reason"] == "timeout" and not row["success"]
    assert "simulated-step budget of 100 steps" in row["error_message"]
    assert row["object_friction"] > 0  # the partial facts gathered before the limit are kept


def test_a_wall_clock_limit_ends_the_episode_as_timeout(tmp_path: Path) -> None:
    spec = _spec(tmp_path, limits={"wall_time_s": 1e-6})
    start = time.perf_counter()
    row = execute(spec, str(tmp_path / "run"), "none")
    assert time.perf_counter() - start < 30
    assert row["failure_reason"] == "timeout"
    assert "wall-clock limit of 1e-06 s" in row["error_message"]
    assert signal.getitimer(signal.ITIMER_REAL) == (0.0, 0.0)  # no alarm left behind


def test_the_alarm_ends_work_that_never_steps_the_physics() -> None:
    start = time.perf_counter()
    with pytest.raises(EpisodeTimeoutError, match="wall-clock limit"), episode_budget(0.2, 10):
        time.sleep(5)  # a planner stuck in a loop would be here
    assert time.perf_counter() - start < 2.0


def test_a_tiny_timestep_is_refused_by_validate_and_run(tmp_path, capsys) -> None:
    """Finding 3: ``physics.timestep: 1e-9`` passed validate and then ran for ever."""
    path = task_file(tmp_path, physics={"timestep": 1e-9, "table_contact": False})
    assert cli.main(["validate", str(path)]) == 1
    err = capsys.readouterr().err
    assert "physics.timestep" in err and "physics steps per control step" in err
    run_dir = tmp_path / "run"
    assert cli.main(["run", str(path), "--episodes", "1", "--out", str(run_dir)]) == 2
    err = capsys.readouterr().err
    assert "physics steps per control step" in err and not run_dir.exists()


def test_a_large_grid_reports_progress_while_it_expands(tmp_path, monkeypatch, capsys) -> None:
    from harness.config import load_sweep
    from harness.runs.expansion import ExpansionProgress, expand

    monkeypatch.setattr(ExpansionProgress, "MIN_POINTS", 10)
    monkeypatch.setattr(ExpansionProgress, "EVERY_S", 0.0)
    sweep = {
        "name": "grid",
        "tasks": [str(FR3)],
        "axes": {"pick.lift_th": [0.01, 0.02, 0.03, 0.04], "pick.t_eps": [0.01, 0.02, 0.03]},
        "episodes_per_point": 1,
    }
    path = tmp_path / "grid.yaml"
    path.write_text(yaml.safe_dump(sweep), encoding="utf-8")
    episodes = expand(load_sweep(path), path, progress=True)
    err = capsys.readouterr().err
    assert len(episodes) == 12
    assert "expanding 12 points" in err and "expanding: 12/12 points" in err
    assert "expanded 12 points" in err


def test_a_huge_mesh_file_is_refused_before_reading(tmp_path, monkeypatch) -> None:
    import harness.objects.meshes as meshes

    monkeypatch.setattr(meshes, "MAX_MESH_BYTES", 100)  # cube.obj: 394 bytes
    with pytest.raises(InputFileError, match="MiB, above the limit"):
        check_task(load_task(task_file(tmp_path)))


def test_coacd_past_its_time_limit_is_a_clear_error(tmp_path, monkeypatch) -> None:
    from harness.objects import coacd_process, shapes
    from harness.objects.assets import ObjectAsset

    mesh = tmp_path / "mug.obj"
    mesh.write_text(shapes.obj_text(shapes.mug()), encoding="utf-8")
    monkeypatch.setenv("PICK_HARNESS_CACHE", str(tmp_path / "cache"))  # nothing cached
    monkeypatch.setattr(coacd_process, "COACD_TIMEOUT_S", 0.01)
    with pytest.raises(InputFileError, match=r"CoACD did not finish within 0\.01 s") as caught:
        ObjectAsset.load(mesh)
    assert caught.value.file == str(mesh) and caught.value.key == "mesh"


# -- deep validation (finding 4) ------------------------------------------------------------------


def _grasp_file(tmp_path: Path, kind: str) -> Path:
    good = np.load(CUBE / "grasps.npy", allow_pickle=False)
    path = tmp_path / f"{kind}.npy"
    if kind == "nan":
        bad = good.copy()
        bad[3, 13] = np.nan
        np.save(path, bad)
    elif kind == "empty":
        np.save(path, good[:0])
    elif kind == "pickled":
        np.save(path, np.array([{"grasp": 1}], dtype=object), allow_pickle=True)
    elif kind == "truncated":
        np.save(path, good)
        path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    elif kind == "wrong_shape":
        np.save(path, good[:, :16])
    return path


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"robot": "ur5"}, "robot: unknown robot 'ur5'"),
        ({"arm": "right"}, "arm: robot 'fr3' has no arm 'right'"),
        ({"home": [0.0, 0.1, 0.2]}, "home: has 3 values; the left arm of fr3 has 7 joints"),
        ({"home": [10.0, 0, 0, -2.0, 0, 2.0, 0.8]}, "home[0]: 10 is outside the limits"),
        ({"objects": [{"name": "c", "mesh": "/nonexistent/m.obj"}]}, "mesh file not found"),
        ({"objects": [{"name": "c", "mesh": "/etc/passwd"}]}, "unsupported mesh format"),
        ({"objects": [{"name": "c", "mesh": "EMPTY"}]}, "mesh is empty"),
        (
            {
                "objects": [
                    {
                        "name": "c",
                        "mesh": "cube",
                        "placement": {"pos_range": [[0.5, 0, -0.03], [0.5, 0, -0.03]]},
                    }
                ]
            },
            "places object 'c' 30 mm inside the table",
        ),
        ({"objects": [{"name": "c", "mesh": "cube", "grasps": "nan"}]}, "is not finite"),
        ({"objects": [{"name": "c", "mesh": "cube", "grasps": "empty"}]}, "holds no grasps"),
        ({"objects": [{"name": "c", "mesh": "cube", "grasps": "pickled"}]}, "allow_pickle"),
        ({"objects": [{"name": "c", "mesh": "cube", "grasps": "truncated"}]}, "cannot read"),
        ({"objects": [{"name": "c", "mesh": "cube", "grasps": "wrong_shape"}]}, "N x 17"),
        ({"objects": [{"name": "c", "mesh": "cube", "grasps": "/etc/passwd"}]}, "cannot read"),
    ],
)
def test_validate_checks_what_a_run_loads(tmp_path, capsys, changes: dict, message: str) -> None:
    """Finding 4: each of these said ``ok`` and then made every row of a run ``error``."""
    for obj in changes.get("objects", []):
        if obj["mesh"] == "EMPTY":
            (tmp_path / "empty.obj").write_text("# nothing\n", encoding="utf-8")
            obj["mesh"] = str(tmp_path / "empty.obj")
        if obj.get("grasps") and not obj["grasps"].startswith("/"):
            obj["grasps"] = str(_grasp_file(tmp_path, obj["grasps"]))
    path = task_file(tmp_path, **changes)
    code = cli.main(["validate", str(path)])
    captured = capsys.readouterr()
    assert code == 1 and "ok " not in captured.out
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), captured.err
    assert message in lines[0]
    assert str(path) in lines[0] or "/" in lines[0].split(":")[1]  # the file is named


def test_run_refuses_broken_input_before_any_episode(tmp_path, capsys) -> None:
    """Finding 4: ``harness run`` exited 0 with every row ``error`` (fr3 with ``arm: right``)."""
    path = task_file(tmp_path, arm="right")
    assert cli.main(["run", str(path), "--episodes", "2", "--out", str(tmp_path / "run")]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        f"error: {path} arm: robot 'fr3' has no arm 'right'; arms: left"
    ]
    assert not (tmp_path / "run").exists()


# -- error rows: out of rates, in the exit code (findings 4, 6) ----------------------------------


def test_error_rows_are_out_of_every_rate_and_fail_the_run(tmp_path, monkeypatch, capsys) -> None:
    import harness.episode

    real = harness.episode.run_episode

    def crash_on_seed_index_1(spec, scene_cache=None, candidate_cache=None):
        if spec.episode_index == 1:
            raise RuntimeError("injected library failure")
        return real(spec, scene_cache=scene_cache, candidate_cache=candidate_cache)

    monkeypatch.setattr(harness.episode, "run_episode", crash_on_seed_index_1)
    run_dir = tmp_path / "run"
    code = cli.main(["run", str(FR3), "--episodes", "3", "--out", str(run_dir)])
    err = capsys.readouterr().err
    assert code == 1
    assert "1 of 3 episode(s) (33%) are error rows, not counted in any success rate" in err
    assert str(run_dir / "episodes.csv") in err
    frame = pd.read_csv(run_dir / "episodes.csv")
    assert (frame["failure_reason"] == "error").sum() == 1
    summary = pd.read_csv(run_dir / "summary.csv")
    assert int(summary["n"].sum()) == 2 and int(summary["errors"].sum()) == 1
    real_successes = int(frame.loc[frame["failure_reason"] != "error", "success"].sum())
    assert int(summary["successes"].sum()) == real_successes
    assert summary["rate"].iloc[0] == pytest.approx(real_successes / 2)


# -- physics sanity (finding 11) ------------------------------------------------------------------


def test_an_object_falling_off_the_scene_is_sim_unstable(tmp_path: Path) -> None:
    """Finding 11: a 71.8 m fall was reported as ``no_contact``."""
    off_table = {"pos_range": [[4.0, 0.0, 0.0], [4.0, 0.0, 0.0]], "yaw_range": [0, 0]}
    data = yaml.safe_load(task_file(tmp_path).read_text(encoding="utf-8"))
    data["objects"][0]["placement"] = off_table
    data["max_episode_length"] = 2000
    path = tmp_path / "off.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    spec = EpisodeSpec(task=load_task(path), seed=1, episode_id="off-e0")
    row = execute(spec, str(tmp_path / "run"), "none")
    assert row["failure_reason"] == "sim_unstable", row["error_message"]
    assert "below the table top: it left the scene" in row["error_message"]


def test_mujoco_log_goes_to_the_run_directory_not_the_cwd(tmp_path, monkeypatch) -> None:
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    monkeypatch.chdir(cwd)
    run_dir = tmp_path / "run"
    spec = _spec(tmp_path, limits={"sim_steps": 100})
    execute(spec, str(run_dir), "none")  # a worker points the log at its run directory
    model = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body><freejoint/><geom size='.1'/></body></worldbody></mujoco>"
    )
    data = mujoco.MjData(model)
    data.qvel[:] = np.nan  # MuJoCo warns: "Nan, Inf or huge value in QVEL"
    mujoco.mj_step(model, data)
    assert data.warning[mujoco.mjtWarning.mjWARN_BADQVEL].number == 1
    assert "QVEL" in (run_dir / "MUJOCO_LOG.TXT").read_text(encoding="utf-8")
    assert not (cwd / "MUJOCO_LOG.TXT").exists()


def test_disk_full_errnos() -> None:
    assert is_disk_full(OSError(errno.ENOSPC, "No space left on device"))
    assert is_disk_full(OSError(errno.EDQUOT, "Disk quota exceeded"))
    assert not is_disk_full(OSError(errno.EACCES, "Permission denied"))


# -- Ray: a killed actor (finding 6) ----------------------------------------------------------


@pytest.mark.slow
@pytest.mark.ray
def test_a_killed_ray_actor_gives_one_retried_episode_not_error_rows(tmp_path, monkeypatch):
    """Finding 6: killing one Ray actor gave two ``error`` rows. The actor's process dies by a
    real SIGSEGV on the victim's first attempt; Ray restarts it and runs the episode again."""
    pytest.importorskip("ray")
    from harness.config import load_sweep
    from harness.runs.expansion import expand
    from harness.runs.sweep import run_sweep

    sweep = {"name": "ray-kill", "tasks": [str(FR3)], "episodes_per_point": 3, "record": "none"}
    sweep_path = tmp_path / "sweep.yaml"
    sweep_path.write_text(yaml.safe_dump(sweep), encoding="utf-8")
    victim = expand(load_sweep(sweep_path), sweep_path)[1].resolved_id
    markers = tmp_path / "markers"
    markers.mkdir()
    import ray.cloudpickle

    ray.cloudpickle.register_pickle_by_value(faults)  # Ray's workers import nothing from tests/
    try:
        faults.install(monkeypatch, segfault=(victim,), once_dir=markers)
        outcome = run_sweep(
            sweep_path, out=tmp_path / "run", backend="ray", workers=2, progress=False
        )
    finally:
        ray.cloudpickle.unregister_pickle_by_value(faults)
    assert (markers / victim).exists()  # the actor did die once
    rows = jsonl_rows(outcome.run_dir)
    assert sorted(row["episode_id"] for row in rows) == sorted(
        e.resolved_id for e in expand(load_sweep(sweep_path), sweep_path)
    )  # every episode once: none lost, none doubled
    assert all(row["failure_reason"] != "error" for row in rows), [
        row["error_message"] for row in rows
    ]
    assert outcome.stats.crashed == 0 and outcome.errors == 0
