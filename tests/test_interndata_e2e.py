"""InternDataEngine task files end to end: the shared example files run through ``harness run
--interndata`` and ``harness sweep`` on real episodes (MuJoCo, placo, TOPP-RA), and bad files
stop the CLI with one located line.

One example object (the bottle, standing in for the reference's absent banana) is used
everywhere, so its convex decomposition is computed once and then read from the cache.
"""

from __future__ import annotations

import json
import subprocess
import sys
import typing
from pathlib import Path

import pandas as pd
import pytest
from helpers import INTERNDATA_ROBOTS_TEXT

from harness.cli import main as cli_main
from harness.config import ConfigError, load_sweep
from harness.failures import FailureReason
from harness.interndata import load_interndata_tasks

PROJECT_ROOT = Path(__file__).resolve().parents[1]
HARNESS = Path(sys.executable).with_name("harness")
EXAMPLE_SWEEP = PROJECT_ROOT / "tasks" / "sweeps" / "interndata_example.yaml"
FAILURE_REASONS = set(typing.get_args(FailureReason)) - {"", "error"}
EPISODES = 10


@pytest.fixture
def bottle(examples_dir: Path) -> Path:
    """The example object substituted for the absent banana (its grasp file sits next to it)."""
    path = examples_dir / "objects" / "recyclable_garbage" / "bottle_0" / "Aligned_obj.usd"
    assert path.is_file() and path.with_name("Aligned_grasp_sparse.npy").is_file()
    return path


def task_file(examples_dir: Path, name: str) -> Path:
    return examples_dir / "tasks" / name


def run_cli(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str]:
    """``harness ARGV...`` in this process (the console script's entry point): (code, stdout)."""
    code = cli_main(list(argv))
    return code, capsys.readouterr().out


def run_cli_subprocess(*argv: str | Path) -> subprocess.CompletedProcess[str]:
    """The installed ``harness`` console script, as a user runs it."""
    return subprocess.run(
        [str(HARNESS), *map(str, argv)],
        capture_output=True,
        text=True,
        cwd=PROJECT_ROOT,
        timeout=120,
    )


def check_rows(
    rows: pd.DataFrame, tasks: dict[str, tuple[str, str]], episodes: int, points: int = 1
) -> None:
    """One row per episode per point per task, each a real verdict: success, or a reason from
    the taxonomy other than ``error``."""
    assert sorted(rows["task"].unique()) == sorted(tasks)
    for name, (robot, arm) in tasks.items():
        own = rows[rows["task"] == name]
        assert sorted(own["episode_index"]) == sorted(list(range(episodes)) * points)
        assert set(own["robot"]) == {robot} and set(own["arm"]) == {arm}
    assert rows["success"].dtype == bool
    failed = rows[~rows["success"]]
    assert set(failed["failure_reason"]) <= FAILURE_REASONS, failed["error_message"].tolist()
    assert rows.loc[rows["success"], "failure_reason"].isna().all()
    # Real episodes: every grasp of the bottle (3000, plus the flipped copies) was considered,
    # candidates were tested by the planner, and what was planned was simulated.
    assert (rows["n_total"] == 6000).all()
    assert (rows["n_tested"] >= 1).all()
    assert (rows.loc[rows["failure_reason"] != "plan_failed", "sim_steps"] > 0).all()
    successes = rows[rows["success"]]
    assert (successes["lift_height_m"] > 0.02).all()  # the files' lift_th
    assert (successes[["finger_force_left_n", "finger_force_right_n"]].max(axis=1) > 0).all()


# --------------------------------------------------------------------------------------------
# The three canonical single-pick files, on their robots

CANONICAL = {
    "franka_single_pick_banana.yaml": ("fr3", "left"),
    "lift2_left_single_pick_banana.yaml": ("lift2", "left"),
    "split_aloha_left_single_pick_banana.yaml": ("split_aloha", "left"),
}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(CANONICAL))
def test_canonical_file_runs_end_to_end(
    examples_dir: Path,
    bottle: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    name: str,
) -> None:
    path = task_file(examples_dir, name)
    out = tmp_path / "run"
    robot, arm = CANONICAL[name]
    # The bottle's USD authors 0.5 kg (the row says so); the small arms' claims below are about
    # reach, so they pick it at 0.1 kg: whether their grippers hold 0.5 kg is a grip question
    # (docs/robots.md, Grippers).
    mass = [] if robot == "fr3" else ["--set", "object.mass=0.1"]
    code, stdout = run_cli(
        capsys,
        "run",
        "--interndata",
        str(path),
        "--object",
        f"pick_object_left={bottle}",
        "--episodes",
        str(EPISODES),
        "--record",
        "none",
        "--out",
        str(out),
        *mass,
    )
    assert code == 0, stdout
    rows = pd.read_csv(out / "episodes.csv")
    assert set(rows["object_mass_kg"]) == ({0.5} if robot == "fr3" else {0.1})
    check_rows(rows, {path.stem: (robot, arm)}, EPISODES)
    successes = int(rows["success"].sum())
    assert f"success {successes}/{EPISODES} = " in stdout
    failures = rows["failure_reason"].value_counts().to_dict()
    print(f"{name}: {successes}/{EPISODES} successes, failures {failures}")

    if robot == "fr3":
        # The file's whole object region is within the FR3's reach (docs/robots.md: 25/25):
        # nothing fails to plan. What is lost is a bottle knocked away by a finger before the
        # closing, so the fingers close on nothing (`no_contact`). Measured on these seeds:
        # episode 6 (a finger hits it in the transport and moves it 61 mm; the same without
        # the noslip pass) and, since the noslip pass (issue 33), episode 1: the right finger
        # lands on it in the approach, the contact no longer creeps, the TCP stalls 38 mm
        # short and drags it 55 mm (`physics.noslip_iterations=0`: the finger slides, the
        # bottle moves 17 mm and is lifted, but turns 44 deg in the hold: not valid). 8/10.
        failed = rows.loc[~rows["success"]]
        assert (failed["failure_reason"] == "no_contact").all(), failed["failure_reason"].tolist()
        fingers = failed[["finger_force_left_n", "finger_force_right_n"]]
        assert (fingers == 0).all().all()
        assert successes >= EPISODES - 2
        return
    # The small arms (Piper, R5a) pick what is in reach: every failure is a reach failure (no IK
    # solution at the pre-grasp, or along the lift line).
    assert successes >= 1
    failed = rows.loc[~rows["success"]]
    assert (failed["failure_reason"] == "plan_failed").all(), failed["failure_reason"].tolist()
    reach = failed["error_message"].str.match(r"^(ik_pregrasp|ik_grasp|lift|approach): ")
    assert reach.all(), failed["error_message"].tolist()
    if robot == "split_aloha":
        # With the arm bases where the reference's converter puts them (13.8 cm closer to the
        # table than the Cobot Magic fixture; docs/robots.md, Reach: 23/25 cells, 14 before)
        # most of the file's region is in reach: 7/10 over these seeds (2/10 before).
        assert successes >= 6
        return
    # The Lift-2's far row (up to 0.69 m from its arm bases) is beyond the R5a's top-down
    # reach: a failure at the pre-grasp is far out of reach, not a near miss (IK residuals of
    # 78-250 mm over these seeds), and a failure at the lift is a grasp that passed the
    # reference's feasibility test (pre-grasp and grasp only, issue 22) whose lift line leaves
    # the arm's reach. (Before issue 22 the failing objects were farther on average; with the
    # lift left out of the test, 3 of the 7 failures are lifts at 0.47-0.60 m.)
    pregrasp = failed[failed["error_message"].str.startswith("ik_pregrasp: ")]
    residual_mm = pregrasp["error_message"].str.extract(r"residual ([0-9.]+) mm")[0].astype(float)
    assert (residual_mm > 50.0).all(), pregrasp["error_message"].tolist()
    lifts = failed[failed["error_message"].str.startswith("lift: ")]
    assert (lifts["n_feasible"] >= 1).all()


# --------------------------------------------------------------------------------------------
# sort_the_rubbish: both arms' picks on split_aloha, place and home skills skipped


@pytest.mark.slow
def test_sort_the_rubbish_runs_both_picks_and_reports_skipped_skills(
    examples_dir: Path, bottle: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = task_file(examples_dir, "split_aloha_sort_the_rubbish.yaml")
    out = tmp_path / "run"
    episodes = 2
    code, stdout = run_cli(
        capsys,
        "run",
        "--interndata",
        str(path),
        "--object",
        f"pick_object_left={bottle}",
        "--object",
        f"pick_object_right={bottle}",
        "--episodes",
        str(episodes),
        "--record",
        "none",
        "--out",
        str(out),
    )
    assert code == 0, stdout
    rows = pd.read_csv(out / "episodes.csv")
    # Phase order: the right arm's pick (phase 0), then the left arm's (phase 1).
    check_rows(
        rows,
        {
            "split_aloha_sort_the_rubbish-0-right": ("split_aloha", "right"),
            "split_aloha_sort_the_rubbish-1-left": ("split_aloha", "left"),
        },
        episodes,
    )
    skipped = [
        "tasks[0].skills[0].split_aloha[0].right[1]: place (split_aloha right)",
        "tasks[0].skills[0].split_aloha[0].right[2]: heuristic__skill mode home "
        "(split_aloha right)",
        "tasks[0].skills[0].split_aloha[1].left[1]: place (split_aloha left)",
        "tasks[0].skills[0].split_aloha[1].left[2]: heuristic__skill mode home (split_aloha left)",
    ]
    lines = [line.strip() for line in stdout.splitlines()]
    assert "skipped 4 skill(s) (pick-harness runs pick skills only):" in lines
    assert all(line in lines for line in skipped)
    assert (
        "split_aloha_sort_the_rubbish-0-right: tasks[0].skills[0].split_aloha[0].right[0] -> "
        "split_aloha right, picks 'pick_object_right' (scene: pick_object_left, "
        "pick_object_right)" in lines
    )
    # The run directory keeps the same list, plus every other note of the mapping.
    notes = (out / "skipped.txt").read_text().splitlines()
    assert all(f"  {line}" in notes for line in skipped)
    assert any("skipped object 'gso_box_left': asset not found" in line for line in notes)
    assert f"{out / 'skipped.txt'}" in stdout
    print(f"sort_the_rubbish: {rows.groupby('task')['success'].sum().to_dict()} of {episodes}")


# --------------------------------------------------------------------------------------------
# A sweep listing InternData files


@pytest.mark.slow
def test_example_sweep_expands_and_runs(examples_dir: Path, bottle: Path, tmp_path: Path) -> None:
    from harness.runs.expansion import expand
    from harness.runs.sweep import run_sweep

    sweep = load_sweep(EXAMPLE_SWEEP)
    episodes = expand(sweep, EXAMPLE_SWEEP)
    names = ["franka_single_pick_banana", "split_aloha_left_single_pick_banana"]
    assert len(episodes) == len(names) * 2 * sweep.episodes_per_point
    assert sorted({e.task_name for e in episodes}) == names
    # The substitution (relative to the sweep file) reached the task, and the swept
    # robot-neutral filter replaced the file's filter on the approach axis (EE z on both
    # robots); the file's facing filter stays.
    facing = {names[0]: "filter_x_dir", names[1]: "filter_y_dir"}
    for episode in episodes:
        pick = episode.task.pick
        assert Path(episode.task.target_object.mesh).resolve() == bottle.resolve()
        assert pick.filter_z_dir is None
        assert pick.approach_filter is not None
        assert pick.approach_filter.as_list() == episode.point["pick.approach_filter"]
        assert getattr(pick, facing[episode.task_name]).as_list() == ["forward", 90.0]

    outcome = run_sweep(
        EXAMPLE_SWEEP,
        out=tmp_path / "sweep",
        backend="serial",
        record="none",
        episodes_per_point=1,
        progress=False,
    )
    rows = pd.read_csv(outcome.run_dir / "episodes.csv")
    assert len(rows) == 4
    assert sorted(map(json.loads, rows["approach_filter"].unique())) == [
        ["downward", 120.0],
        ["downward", 140.0],
    ]
    check_rows(rows, {names[0]: ("fr3", "left"), names[1]: ("split_aloha", "left")}, 1, 2)
    print(f"sweep: {int(rows['success'].sum())}/4 successes")


# --------------------------------------------------------------------------------------------
# Bad files through the CLI: one line naming the file and the key, non-zero exit


def line_of(path: Path, fragment: str) -> int:
    return next(i for i, line in enumerate(path.read_text().splitlines(), 1) if fragment in line)


def broken_copy(examples_dir: Path, tmp_path: Path, old: str, new: str) -> Path:
    source = task_file(examples_dir, "franka_single_pick_banana.yaml")
    text = source.read_text()
    assert old in text
    path = tmp_path / "broken.yaml"
    path.write_text(text.replace(old, new, 1))
    return path


def assert_one_line_error(result: subprocess.CompletedProcess[str], expected: str) -> None:
    assert result.returncode != 0
    assert "Traceback" not in result.stderr
    errors = [line for line in result.stderr.splitlines() if line.startswith("error:")]
    assert errors == [expected], result.stderr
    assert "episodes" not in result.stdout  # nothing ran


def test_cli_unsupported_robot(examples_dir: Path, bottle: Path, tmp_path: Path) -> None:
    path = broken_copy(examples_dir, tmp_path, "robots/fr3.yaml", "robots/genie1.yaml")
    result = run_cli_subprocess(
        "run", "--interndata", path, "--object", f"pick_object_left={bottle}"
    )
    assert_one_line_error(
        result,
        f"error: {path}:{line_of(path, 'robot_config_file')} "
        "tasks[0].robots[0].robot_config_file: unsupported robot 'genie1.yaml' "
        "(workflows/simbox/core/configs/robots/genie1.yaml); supported: " + INTERNDATA_ROBOTS_TEXT,
    )


def test_cli_missing_asset(examples_dir: Path) -> None:
    path = task_file(examples_dir, "franka_single_pick_banana.yaml")
    result = run_cli_subprocess("run", "--interndata", path, "--asset-root", "/nonexistent")
    asset = "/nonexistent/pick_and_place/pre-train-pick/assets/omniobject3d-banana/"
    assert_one_line_error(
        result,
        f"error: {path}:{line_of(path, 'path: pick_and_place')} tasks[0].objects[0].path: "
        f"asset not found: {asset}omniobject3d-banana_001/Aligned_obj.usd "
        "(substitute it with --object pick_object_left=PATH)",
    )


def test_cli_broken_interpolation(examples_dir: Path, bottle: Path, tmp_path: Path) -> None:
    path = broken_copy(
        examples_dir,
        tmp_path,
        "object: ${tasks.0.robots.0.name}",
        "object: ${tasks.0.robots.0.nmae}",
    )
    result = run_cli_subprocess(
        "run", "--interndata", path, "--object", f"pick_object_left={bottle}"
    )
    assert_one_line_error(
        result,
        f"error: {path}:{line_of(path, 'robots.0.nmae')} tasks[0].regions[1].object: "
        "interpolation ${tasks.0.robots.0.nmae}: key 'tasks[0].robots[0].nmae' not found; "
        "did you mean 'name'?",
    )


def test_missing_grasp_file_is_one_located_error(
    examples_dir: Path, bottle: Path, tmp_path: Path
) -> None:
    """A picked asset without its grasp file fails up front (as ``harness run`` loads files),
    not as an ``error`` row per episode."""
    lone = tmp_path / "Aligned_obj.usd"
    lone.write_bytes(bottle.read_bytes())
    path = task_file(examples_dir, "franka_single_pick_banana.yaml")
    with pytest.raises(ConfigError) as info:
        load_interndata_tasks(path, None, {"pick_object_left": str(lone)}, check_grasps=True)
    assert info.value.one_line() == (
        f"{path}:{line_of(path, 'path: pick_and_place')} tasks[0].objects[0].path: no grasp "
        f"file next to the asset: {tmp_path / 'Aligned_grasp_sparse.npy'} (the pick reads its "
        "npy_name, default Aligned_grasp_sparse.npy, next to the USD)"
    )
