"""``--engine mjwarp`` fails like the rest: one line at start, before a run directory is made,
when the ``gpu`` extra or a device is missing; ``--resume`` keeps the run's engine (issue 36)."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from harness.cli import main
from harness.errors import HarnessError
from harness.runs import engine_check
from harness.runs.engine_check import (
    ENGINE_FILE,
    check_engine,
    device_problem,
    recorded_engine,
)
from harness.runs.sweep import run_sweep

ROOT = Path(__file__).resolve().parents[1]
FR3 = ROOT / "tasks" / "pick" / "fr3.yaml"


@pytest.fixture
def without_gpu_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    """A module of the extra that is not importable anywhere: the check on a real find_spec."""
    monkeypatch.setattr(engine_check, "GPU_MODULES", ("mujoco_warp_not_installed_s36",))


def test_device_problem_names_what_is_missing_and_how_to_opt_in() -> None:
    assert device_problem(None, 1) is None
    assert device_problem("cpu", 0) is None
    assert device_problem("cuda:0,cuda:1", 2) is None
    no_gpu = device_problem(None, 0)
    assert no_gpu is not None and "no CUDA device" in no_gpu
    assert "HARNESS_WARP_DEVICE=cpu" in no_gpu and "--engine mujoco" in no_gpu
    absent = device_problem("cuda:0,cuda:2", 2)
    assert absent is not None and "no device cuda:2" in absent and "2 CUDA device(s)" in absent
    typo = device_problem("gpu0", 1)
    assert typo is not None and "'gpu0' is not a Warp device" in typo


def test_check_engine_without_a_device_is_one_line(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(engine_check, "missing_gpu_modules", lambda: [])
    monkeypatch.delenv("HARNESS_WARP_DEVICE", raising=False)
    with pytest.raises(HarnessError, match="Warp sees no CUDA device") as info:
        check_engine("mjwarp", cuda_count=lambda: 0)
    assert "\n" not in str(info.value)
    monkeypatch.setenv("HARNESS_WARP_DEVICE", "cpu")
    check_engine("mjwarp", cuda_count=lambda: 0)  # Warp's CPU device, asked for by name
    check_engine("mujoco", cuda_count=lambda: 0)


@pytest.mark.parametrize("command", ["run", "sweep", "tune"])
def test_mjwarp_without_the_extra_is_one_line_and_writes_nothing(
    command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], without_gpu_extra: None
) -> None:
    out = tmp_path / "out"
    source = str(ROOT / "tasks" / "sweeps" / "demo.yaml") if command == "sweep" else str(FR3)
    assert main([command, source, "--engine", "mjwarp", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "needs the 'gpu' extra" in err[0], err
    assert "pip install 'pick-harness[gpu]'" in err[0]
    assert not out.exists()  # no run directory whose --resume would run something else


def _small_sweep(tmp_path: Path) -> Path:
    path = tmp_path / "small.yaml"
    sweep = {"name": "small", "tasks": [str(FR3)], "episodes_per_point": 1, "record": "none"}
    path.write_text(yaml.safe_dump(sweep), encoding="utf-8")
    return path


def test_resume_keeps_the_runs_engine_or_refuses_another(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], without_gpu_extra: None
) -> None:
    run_dir = tmp_path / "run"
    run_sweep(_small_sweep(tmp_path), out=run_dir, backend="serial", progress=False, limit=0)
    assert (run_dir / ENGINE_FILE).read_text(encoding="utf-8") == "mujoco\n"
    # Another engine on resume: refused with one line, the run untouched.
    assert main(["sweep", "--resume", str(run_dir), "--engine", "mjwarp"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "executes on engine 'mujoco'; --resume keeps it" in err[0]
    # A run made on the GPU engine, resumed where the extra is missing: the one-line refusal,
    # not a silent switch to the CPU engine.
    (run_dir / ENGINE_FILE).write_text("mjwarp\n", encoding="utf-8")
    with pytest.raises(HarnessError, match="needs the 'gpu' extra"):
        run_sweep(resume_dir=run_dir, backend="serial", progress=False, limit=0)
    # The same engine named again, or none: the run's own.
    (run_dir / ENGINE_FILE).write_text("mujoco\n", encoding="utf-8")
    outcome = run_sweep(
        resume_dir=run_dir, backend="serial", progress=False, limit=1, engine="mujoco"
    )
    assert outcome.stats.finished == 1


def test_recorded_engine_of_a_run_without_the_file_comes_from_its_rows(tmp_path: Path) -> None:
    assert recorded_engine(tmp_path, ["mjwarp", "mjwarp"]) == "mjwarp"
    assert recorded_engine(tmp_path, []) == "mujoco"
    (tmp_path / ENGINE_FILE).write_text("mjwarp\n", encoding="utf-8")
    assert recorded_engine(tmp_path, ["mujoco"]) == "mjwarp"
