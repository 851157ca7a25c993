"""Physics settings measured to break friction holds are warned by validate, run and sweep
(``harness.config.physics_warnings``; the measurements are in its docstring and docs/config.md)."""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers import harness

from harness.config import PhysicsConfig, physics_warnings

PROJECT_ROOT = Path(__file__).resolve().parents[1]
BAD_TASK = """\
name: bad_physics
robot: fr3
objects:
  - name: cube
    mesh: cube
physics:
  timestep: 0.01
  cone: pyramidal
  impratio: 1
"""


def keys(**physics) -> list[str]:
    return [key for key, _ in physics_warnings(PhysicsConfig(**physics))]


def test_defaults_and_measured_safe_settings_give_no_warning() -> None:
    assert keys() == []
    assert keys(timestep=0.006) == []
    assert keys(cone="pyramidal", impratio=5) == []
    assert keys(cone="elliptic", impratio=3) == []


def test_settings_that_dropped_holds_are_warned() -> None:
    assert keys(timestep=0.008) == ["physics.timestep"]
    assert keys(cone="pyramidal", impratio=3) == ["physics.impratio"]
    assert keys(cone="elliptic", impratio=1) == ["physics.impratio"]
    assert keys(timestep=0.01, cone="pyramidal", impratio=1) == [
        "physics.timestep",
        "physics.impratio",
    ]


def test_validate_warns_with_file_and_key(tmp_path: Path) -> None:
    task = tmp_path / "bad.yaml"
    task.write_text(BAD_TASK)
    sweep = tmp_path / "sweep.yaml"
    sweep.write_text(
        "name: s\ntasks: [bad.yaml]\naxes:\n  physics.impratio: [1, 10]\nepisodes_per_point: 1\n"
    )
    result = harness("validate", task, sweep, PROJECT_ROOT / "tasks" / "pick" / "fr3.yaml")
    assert result.returncode == 0, result.stderr  # warnings do not fail validation
    lines = result.stderr.splitlines()
    assert lines[0].startswith(f"warning: {task}: physics.timestep: 0.01 s is above 0.006 s")
    assert lines[1].startswith(f"warning: {task}: physics.impratio: 1 with pyramidal cones")
    # the sweep: the timestep comes from the task file, impratio 1 from the swept point 0
    assert lines[2].startswith(f"warning: {task}: physics.timestep:")
    assert lines[2].endswith("(task 'bad_physics')")
    assert lines[3].startswith(f"warning: {sweep}: physics.impratio: 1 with pyramidal")
    assert lines[3].endswith("(task 'bad_physics', point 0 {'physics.impratio': 1})")
    assert len(lines) == 4  # nothing for fr3.yaml, nothing for impratio 10


@pytest.mark.parametrize("command", ["run", "sweep"])
def test_run_and_sweep_warn(tmp_path: Path, command: str, capsys) -> None:
    from harness.cli import main

    task = tmp_path / "bad.yaml"
    task.write_text(BAD_TASK)
    if command == "run":
        args = ["run", str(task), "--episodes", "1", "--set", "physics.timestep=0.004"]
    else:
        sweep = tmp_path / "sweep.yaml"
        sweep.write_text(
            "name: s\ntasks: [bad.yaml]\naxes:\n  physics.timestep: [0.004]\n"
            "episodes_per_point: 1\n"
        )
        args = ["sweep", str(sweep), "--no-progress", "--backend", "serial"]
    assert main([*args, "--record", "none", "--out", str(tmp_path / "out")]) == 0
    warnings = [line for line in capsys.readouterr().err.splitlines() if "warning:" in line]
    assert [line.split(": ")[2] for line in warnings] == ["physics.impratio"]  # 4 ms is safe
    assert warnings[0].startswith(f"warning: {task}: physics.impratio: 1 with pyramidal")
