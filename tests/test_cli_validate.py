"""``harness validate`` as a user runs it: the installed console script in a subprocess."""

from __future__ import annotations

from pathlib import Path

from helpers import EXAMPLES, INTERNDATA_ROBOTS_TEXT, harness


def test_valid_task() -> None:
    result = harness("validate", EXAMPLES / "fr3_cube.yaml")
    assert result.returncode == 0, result.stderr
    assert result.stderr == ""
    assert result.stdout.strip() == (
        f"ok {EXAMPLES / 'fr3_cube.yaml'}: task 'fr3_cube': robot fr3 arm left, objects [cube], "
        "filters {'filter_x_dir': ['forward', 90.0], 'filter_z_dir': ['downward', 140.0]}, "
        "test_mode ik, semantics reference"
    )


def test_valid_sweeps() -> None:
    result = harness(
        "validate", "tasks/examples/sweep_downward.yaml", "tasks/examples/sweep_random.yaml"
    )
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines == [
        "ok tasks/examples/sweep_downward.yaml: sweep 'fr3-downward-cone': 1 task(s), grid over "
        "['pick.filter_z_dir', 'pick.pre_grasp_offset'] = 6 point(s) x 10 episodes, seed 0",
        "ok tasks/examples/sweep_random.yaml: sweep 'neutral-random': 2 task(s), random over "
        "['pick.post_grasp_offset_max', 'object.friction'] = 20 point(s) x 5 episodes, seed 7",
    ]


def test_invalid_file_one_line_no_traceback() -> None:
    result = harness("validate", "tasks/examples/invalid/unknown_pick_key.yaml")
    assert result.returncode != 0
    assert result.stdout == ""
    assert result.stderr == (
        "error: tasks/examples/invalid/unknown_pick_key.yaml:9 pick.filter_z_dri: unknown key; "
        "did you mean 'filter_z_dir'?\n"
    )


def test_every_invalid_example_fails_with_one_located_line() -> None:
    paths = sorted((EXAMPLES / "invalid").glob("*.yaml"))
    result = harness("validate", *paths)
    assert result.returncode != 0
    errors = result.stderr.splitlines()
    assert len(errors) == len(paths)
    for path, line in zip(paths, errors, strict=True):
        assert line.startswith(f"error: {path}:")
    assert "Traceback" not in result.stderr


def test_mixed_files_report_each_and_fail() -> None:
    result = harness(
        "validate", "tasks/examples/fr3_cube.yaml", "tasks/examples/invalid/bad_direction.yaml"
    )
    assert result.returncode == 1
    assert result.stdout.startswith("ok tasks/examples/fr3_cube.yaml: task 'fr3_cube'")
    assert result.stderr.startswith("error: tasks/examples/invalid/bad_direction.yaml:7 ")


def test_missing_file_and_non_config(tmp_path: Path) -> None:
    result = harness("validate", tmp_path / "absent.yaml")
    assert result.returncode != 0
    assert result.stderr == f"error: {tmp_path / 'absent.yaml'}: file not found\n"
    other = tmp_path / "other.yaml"
    other.write_text("hello: world\n")
    result = harness("validate", other)
    assert result.returncode != 0
    assert result.stderr.startswith(f"error: {other}:1: not a task")


def test_binary_file(tmp_path: Path) -> None:
    path = tmp_path / "binary.yaml"
    path.write_bytes(bytes(range(256)))
    result = harness("validate", path)
    assert result.returncode != 0
    assert result.stderr.count("\n") == 1
    assert result.stderr.startswith(f"error: {path}: cannot read file")


def test_help_and_version() -> None:
    result = harness("--version")
    assert result.returncode == 0
    assert result.stdout.startswith("pick-harness ")
    result = harness("validate", "--help")
    assert result.returncode == 0 and "FILE" in result.stdout


# --------------------------------------------------------------------------------------------
# InternDataEngine task files


def test_interndata_files(examples_dir: Path) -> None:
    tasks = examples_dir / "tasks"
    result = harness(
        "validate",
        tasks / "franka_single_pick_banana.yaml",
        tasks / "split_aloha_sort_the_rubbish.yaml",
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines() == [
        f"ok {tasks / 'franka_single_pick_banana.yaml'}: InternDataEngine task file, "
        "1 pick task(s)",
        "  pick 0 tasks[0].skills[0].franka[0].left[0]: task 'franka_single_pick_banana', "
        "robot fr3 ('franka' in the file) arm left, object 'pick_object_left'",
        f"ok {tasks / 'split_aloha_sort_the_rubbish.yaml'}: InternDataEngine task file, "
        "2 pick task(s)",
        "  pick 0 tasks[0].skills[0].split_aloha[0].right[0]: task "
        "'split_aloha_sort_the_rubbish-0-right', robot split_aloha arm right, "
        "object 'pick_object_right'",
        "  pick 1 tasks[0].skills[0].split_aloha[1].left[0]: task "
        "'split_aloha_sort_the_rubbish-1-left', robot split_aloha arm left, "
        "object 'pick_object_left'",
    ]
    # The skipped place / home skills are reported as warnings.
    assert "skipping 2 'place' skill(s)" in result.stderr
    assert "skipping 2 'heuristic__skill' skill(s)" in result.stderr


def test_interndata_unsupported_robot(examples_dir: Path, tmp_path: Path) -> None:
    text = (examples_dir / "tasks" / "lift2_left_single_pick_banana.yaml").read_text()
    path = tmp_path / "genie.yaml"
    path.write_text(text.replace("robots/lift2.yaml", "robots/genie1.yaml"))
    result = harness("validate", path)
    assert result.returncode != 0
    line = next(
        i for i, row in enumerate(path.read_text().splitlines(), 1) if "robot_config_file" in row
    )
    assert result.stderr == (
        f"error: {path}:{line} tasks[0].robots[0].robot_config_file: unsupported robot "
        "'genie1.yaml' (workflows/simbox/core/configs/robots/genie1.yaml); supported: "
        f"{INTERNDATA_ROBOTS_TEXT}\n"
    )
