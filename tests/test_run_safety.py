"""A run stays inside its run directory, never follows a planted symlink, never shares its
directory with a second process, never resumes an edited sweep silently, and rejects YAML tags
that are not plain data (issue 15, findings 1, 7, 8, 9, 10, 11)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from harness.config import ConfigError, load_task
from harness.config.yamlio import parse_yaml
from harness.episode import EpisodeSpec
from harness.runs.rundir import RunDir
from harness.runs.safety import RunLock, inside, safe_file_name
from harness.runs.sweep import run_sweep
from harness.runs.worker import execute

ROOT = Path(__file__).resolve().parents[1]


def tiny_sweep(tmp_path: Path, name: str = "safety", seed: int = 5) -> Path:
    sweep = {
        "name": name,
        "tasks": [str(ROOT / "tasks" / "pick" / "fr3.yaml")],
        "episodes_per_point": 1,
        "seed": seed,
        "record": "none",
    }
    path = tmp_path / "sweep.yaml"
    path.write_text(yaml.safe_dump(sweep), encoding="utf-8")
    return path


def test_safe_file_names_cannot_leave_their_folder() -> None:
    assert safe_file_name("fr3_pick_cube-e0000-7e23045bb1", ".rrd") == (
        "fr3_pick_cube-e0000-7e23045bb1.rrd"
    )
    hostile = safe_file_name("../../../../tmp/x", ".rrd")
    assert "/" not in hostile and not hostile.startswith(".")
    assert hostile.startswith("tmp_x-") and hostile.endswith(".rrd")
    # Distinct hostile names stay distinct (the hash of the original is kept).
    assert safe_file_name("a/b") != safe_file_name("a_b")
    assert len(safe_file_name("x" * 1000)) < 140
    with pytest.raises(ConfigError, match="outside the run directory"):
        inside(Path("/tmp/run"), Path("/tmp/run/../elsewhere"))


def test_a_hostile_task_name_records_inside_the_run_directory(tmp_path: Path) -> None:
    """Finding 1: ``name: ../../../../tmp/x`` wrote its recording outside ``--out``."""
    task = load_task(ROOT / "tasks" / "pick" / "fr3.yaml")
    hostile = f"../../../../{tmp_path.name}-escaped/x"
    task = task.model_copy(update={"name": hostile})
    run_dir = tmp_path / "run"
    spec = EpisodeSpec(task=task, seed=1, record=True)
    row = execute(spec, str(run_dir), "all")
    assert row["recording"], row.get("recording_error")
    recording = run_dir / row["recording"]
    assert recording.is_file() and recording.parent == run_dir / "episodes"
    assert not (tmp_path.parent / f"{tmp_path.name}-escaped").exists()
    default = RunDir.default_path(hostile)
    assert default.parent == Path("reports") and "/" not in default.name


@pytest.mark.parametrize("planted", ["summary.csv", "report.html", ".episodes.csv.tmp", "episodes"])
def test_planted_symlinks_are_refused(tmp_path: Path, planted: str) -> None:
    """Finding 9: symlinks in a run directory were followed and their targets overwritten."""
    victim = tmp_path / "victim.txt"
    victim.write_text("precious", encoding="utf-8")
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    (run_dir / planted).symlink_to(victim)
    with pytest.raises(ConfigError, match="symlink"):
        run_sweep(tiny_sweep(tmp_path), out=run_dir, backend="serial", progress=False)
    assert victim.read_text(encoding="utf-8") == "precious"
    assert not (run_dir / "sweep.yaml").exists()


def test_a_locked_run_directory_is_refused_and_released_after_a_run(tmp_path: Path) -> None:
    """Finding 8: two ``--resume`` of one run both ran the same episodes."""
    run_dir = tmp_path / "run"
    outcome = run_sweep(tiny_sweep(tmp_path), out=run_dir, backend="serial", progress=False)
    assert outcome.stats.finished == 1
    # Another process holds the run.
    with RunLock(run_dir), pytest.raises(ConfigError, match=r"in use by harness pid \d+"):
        run_sweep(resume_dir=run_dir, backend="serial", progress=False)
    # Released: the resume goes through and finds nothing left to run.
    again = run_sweep(resume_dir=run_dir, backend="serial", progress=False)
    assert again.skipped_existing == 1 and again.stats.finished == 0
    lines = (run_dir / "episodes.jsonl").read_text(encoding="utf-8").splitlines()
    assert len(lines) == 1


def test_a_second_process_cannot_enter_a_locked_run(tmp_path: Path) -> None:
    """The lock holds across processes (flock), which is what two CLI invocations are."""
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    code = (
        "import sys; from pathlib import Path; from harness.runs.safety import RunLock\n"
        "from harness.config import ConfigError\n"
        "try:\n    RunLock(Path(sys.argv[1])).acquire()\nexcept ConfigError as e:\n"
        "    print(e); sys.exit(3)\n"
    )
    with RunLock(run_dir):
        result = subprocess.run(
            [sys.executable, "-c", code, str(run_dir)],
            capture_output=True,
            text=True,
            check=False,
            env={**os.environ, "PYTHONPATH": str(ROOT)},
        )
    assert result.returncode == 3, result.stderr
    assert f"in use by harness pid {os.getpid()}" in result.stdout


def test_resume_refuses_an_edited_sweep_unless_forced(tmp_path: Path) -> None:
    """Finding 7: ``--resume`` after editing the run's sweep.yaml mixed configurations."""
    run_dir = tmp_path / "run"
    run_sweep(tiny_sweep(tmp_path), out=run_dir, backend="serial", progress=False)
    sweep_yaml = run_dir / "sweep.yaml"
    sweep_yaml.write_text(sweep_yaml.read_text().replace("seed: 5", "seed: 6"), encoding="utf-8")
    with pytest.raises(ConfigError, match=r"sweep\.yaml changed since the run was created"):
        run_sweep(resume_dir=run_dir, backend="serial", progress=False)
    forced = run_sweep(resume_dir=run_dir, backend="serial", progress=False, force=True)
    assert forced.total == 1


@pytest.mark.parametrize(
    "text",
    [
        "name: x\nrobot: !!python/object/apply:os.system ['echo pwned']\n",
        "name: !custom x\n",
        "objects:\n  - !!python/name:os.system {}\n",
    ],
)
def test_unsafe_yaml_tags_are_errors(text: str) -> None:
    """Finding 11: ``!!python/object/apply`` tags were silently dropped and the file was ok."""
    with pytest.raises(yaml.YAMLError, match="unsupported YAML tag"):
        parse_yaml(text)


def test_cli_validate_rejects_an_unsafe_tag(tmp_path: Path) -> None:
    task = (ROOT / "tasks" / "pick" / "fr3.yaml").read_text(encoding="utf-8")
    bad = tmp_path / "task.yaml"
    bad.write_text(task + "extra: !!python/object/apply:os.system ['true']\n", encoding="utf-8")
    result = subprocess.run(
        [sys.executable, "-m", "harness.cli", "validate", str(bad)],
        capture_output=True,
        text=True,
        check=False,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    assert result.returncode != 0
    assert "unsupported YAML tag" in result.stderr + result.stdout
    assert str(bad) in result.stderr + result.stdout


def harness_cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "harness.cli", *args],
        capture_output=True,
        text=True,
        check=False,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        timeout=120,
    )


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("run", "tasks/pick/fr3.yaml", "--episodes", "1000000000"), "--episodes: 1000000000"),
        (("run", "tasks/pick/fr3.yaml", "--seed", "-1"), "--seed: -1 is outside"),
        (("run", "tasks/pick/fr3.yaml", "--record", "bogus"), "expected none, failures"),
        (("sweep", "tasks/sweeps/demo.yaml", "--episodes-per-point", "0"), "0 is outside"),
        (("sweep", "tasks/sweeps/demo.yaml", "--workers", "x"), "'x' is not an integer"),
    ],
)
def test_bad_flags_are_one_line_usage_errors(args: tuple[str, ...], message: str) -> None:
    """Finding 5: these were tracebacks (or a run of 10^9 episodes)."""
    result = harness_cli(*args)
    assert result.returncode == 2
    assert message in result.stderr and "Traceback" not in result.stderr


def test_an_oversized_sweep_is_refused_before_expansion(tmp_path: Path) -> None:
    """Finding 3: a 10^6-episode sweep sat in expansion with no output."""
    sweep = {
        "name": "big",
        "tasks": [str(ROOT / "tasks" / "pick" / "fr3.yaml")],
        "axes": {"pick.lift_th": [0.01 * i for i in range(1, 101)]},
        "episodes_per_point": 10_000,
    }
    path = tmp_path / "big.yaml"
    path.write_text(yaml.safe_dump(sweep), encoding="utf-8")
    result = harness_cli("sweep", str(path), "--out", str(tmp_path / "run"))
    assert result.returncode == 2
    assert "asks for 1,000,000 episodes" in result.stderr
    assert "--max-episodes 1000000" in result.stderr
    assert not (tmp_path / "run").exists()


def test_an_oversized_yaml_file_is_refused(tmp_path: Path) -> None:
    """Finding 3: a 60 MB YAML was still parsing after 90 s."""
    from harness.config.loading import MAX_YAML_BYTES

    path = tmp_path / "huge.yaml"
    with open(path, "w", encoding="utf-8") as handle:
        handle.write("name: huge\nnotes:\n")
        line = "  - " + "x" * 1000 + "\n"
        for _ in range(MAX_YAML_BYTES // len(line) + 1):
            handle.write(line)
    result = harness_cli("validate", str(path))
    assert result.returncode != 0
    assert "too large for a task or sweep file" in result.stderr + result.stdout


@pytest.mark.parametrize(
    ("command", "path", "hint"),
    [
        ("sweep", "tasks/pick/fr3.yaml", "this is a task file; run it with `harness run"),
        ("run", "tasks/sweeps/demo.yaml", "this is a sweep file; run it with `harness sweep"),
    ],
)
def test_a_file_of_the_other_kind_says_which_command_it_needs(
    command: str, path: str, hint: str
) -> None:
    """Issue 14: ``harness sweep TASK.yaml`` answered "robot: unknown key"."""
    result = harness_cli(command, str(ROOT / path), "--out", "/nonexistent/never-created")
    assert result.returncode == 2
    assert hint in result.stderr and "unknown key" not in result.stderr
