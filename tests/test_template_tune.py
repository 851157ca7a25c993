"""The template tune: one filter setting for a folder of per-object InternDataEngine task files.

Grouping (files identical but for the object form one template; others groups of their own,
with the keys that differ), the line edits that write only filter lines, the exception tests'
Holm decision, and one template tune end to end on a small folder of the project's own objects
in the reference's layout (``harness objects library`` + ``harness objects tasks``).
"""

from __future__ import annotations

import difflib
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from harness.config.line_edit import parse_key_path, set_values
from harness.errors import HarnessError
from harness.tuning.decide import VERDICTS, Racer
from harness.tuning.exceptions import ExceptionTest, decide_exceptions
from harness.tuning.templates import body_of, group_files

FR3_FOLDER = Path("tasks") / "folders" / "fr3_single_pick"
BALL = "omniobject3d-ball.yaml"
PICK_PATH = "tasks[0].skills[0].franka[0].left[0]"


def _changed(before: str, after: str) -> list[str]:
    """The lines of ``before`` that ``after`` changed (unified diff, '-' side)."""
    diff = difflib.unified_diff(before.splitlines(), after.splitlines(), lineterm="", n=0)
    return [d[1:].strip() for d in diff if d.startswith("-") and not d.startswith("---")]


def test_reference_folder_files_differ_only_in_the_object(examples_dir: Path) -> None:
    """The shared FR3 folder's 103 files are one template; a file with another filter is not."""
    from harness.config import read_yaml

    folder = examples_dir / FR3_FOLDER
    files = sorted(folder.glob("*.yaml"))
    assert len(files) >= 100
    bodies = {f: body_of(read_yaml(f).data) for f in files}
    groups = group_files(bodies)
    assert len(groups) == 1 and len(groups[0].files) == len(files)
    data = read_yaml(files[0]).data
    data["tasks"][0]["skills"][0]["franka"][0]["left"][0]["filter_z_dir"] = ["downward", 120]
    bodies[Path("/elsewhere/odd.yaml")] = body_of(data)
    groups = group_files(bodies)
    assert [len(g.files) for g in groups] == [len(files), 1]
    assert groups[1].differs == (f"{PICK_PATH}.filter_z_dir",)


def test_filter_lines_are_the_only_lines_a_write_changes(examples_dir: Path) -> None:
    """Setting, adding and removing pick keys in a reference file touches those lines only."""
    text = (examples_dir / FR3_FOLDER / BALL).read_text()
    keys = {
        "filter_z_dir": ["downward", 160],
        "filter_x_dir": None,
        "filter_y_dir": ["forward", 45],
    }
    edited = set_values(text, {parse_key_path(PICK_PATH): keys})
    assert _changed(text, edited) == [
        'filter_x_dir: ["forward", 90]',
        'filter_z_dir: ["downward", 140]',
    ]
    added = [d for d in difflib.ndiff(text.splitlines(), edited.splitlines()) if d[:1] == "+"]
    assert [a[2:].strip() for a in added] == [
        'filter_z_dir: ["downward", 160]',
        'filter_y_dir: ["forward", 45]',
    ]
    with pytest.raises(HarnessError, match="no key"):
        set_values(text, {parse_key_path("tasks[0].skills[0].lift2[0].left[0]"): keys})


def _test(group: str, task: str, best: list[bool], template: list[bool]) -> ExceptionTest:
    return ExceptionTest(
        group,
        task,
        "{}",
        Racer(("t", "t"), 0, outcomes=list(template)),
        Racer(("b", "b"), 1, outcomes=list(best)),
    )


def test_an_override_needs_its_gain_confirmed_after_holm() -> None:
    """Of three objects' own settings, a large gain is confirmed; a gain whose raw p-value
    passes 0.05 but not Holm's step over the three is not; a loss is not."""
    seeds = 40
    strong = _test("g", "a", [True] * 30 + [False] * 10, [True] * 10 + [False] * 30)
    # 6 seeds won, 0 lost: one-sided exact p = 1/64 = 0.016 < 0.05, but Holm's second step
    # over three tests (x 2) gives 0.031 and the third (x 1) is larger: see the ordering below
    marginal = _test("g", "b", [True] * 6 + [False] * 34, [False] * 40)
    losing = _test("g", "c", [False] * 40, [True] * 5 + [False] * 35)
    decide_exceptions([strong, marginal, losing], seeds, alpha=0.05)
    assert strong.confirmed and strong.p_holm < 1e-4
    assert marginal.p_value == pytest.approx(1 / 64)
    assert marginal.p_holm == pytest.approx(2 / 64)  # Holm's second step: p x 2
    assert marginal.confirmed  # 0.031 < 0.05: still confirmed after Holm
    assert not losing.confirmed
    # with five objects tested, the same marginal gain is no longer confirmed (x 4 > 0.05)
    others = [_test("g", f"n{i}", [False] * 40, [False] * 40) for i in range(3)]
    again = _test("g", "b", [True] * 6 + [False] * 34, [False] * 40)
    decide_exceptions([_test("g", "a", strong.best.outcomes, strong.template.outcomes),
                       again, *others], seeds, alpha=0.05)  # fmt: skip
    assert again.p_holm == pytest.approx(4 / 64) and not again.confirmed
    short = _test("g", "d", [True] * 20, [False] * 20)  # an interrupted test: 20 of 40 seeds
    decide_exceptions([short], seeds, alpha=0.05)
    assert not short.confirmed and np.isnan(short.p_value)


@pytest.mark.slow
def test_template_tune_end_to_end_on_a_small_folder(examples_dir: Path, tmp_path: Path) -> None:
    """Four library objects from the FR3 folder's template with a broad approach filter
    (`downward 90`: side approaches, which are not physically valid here), plus one file with
    another facing filter: two groups; the template's race switches the group to a narrow
    approach on the pooled pairs; every object gets a row; --write changes only filter lines.
    Then two exception tests on real episodes against the broad template: the ball's own best
    (straight down) is confirmed after Holm, the tin's (it succeeds either way) is not."""
    from harness.interndata.generate import generate_task_files
    from harness.objects.library import build_library
    from harness.runs.expansion import load_sweep_tasks
    from harness.runs.rundir import RunDir
    from harness.tuning.exceptions import run_exceptions
    from harness.tuning.options import TuneOptions
    from harness.tuning.run import tune

    library = tmp_path / "objects"
    build_library(library, count=4, grasps=3000, say=lambda _line: None)
    source = (examples_dir / FR3_FOLDER / BALL).read_text()
    broad = source.replace('filter_z_dir: ["downward", 140]', 'filter_z_dir: ["downward", 90]')
    template = tmp_path / "template.yaml"
    template.write_text(broad)
    folder = tmp_path / "folder"
    files = generate_task_files(template, [library], folder)
    assert len(files) == 4
    odd = folder / "zz-odd.yaml"  # another filter: a group of its own
    odd.write_text(files[0].read_text().replace('["forward", 90]', '["forward", 120]'))
    lines: list[str] = []
    options = TuneOptions(
        screen_seeds=3, top=1, block=10, max_seeds=10, exception_seeds=8, coarse=False
    )
    # --step 80: approach downward 90 (the template) and 170, facing forward 90, 160, 180
    out = tmp_path / "tune"
    result = tune(
        [folder], step=80, bands=0, out=out, options=options, workers=2,
        write=tmp_path / "written", announce=lines.append,
    )  # fmt: skip
    assert not result.interrupted
    assert any(line.startswith("template group folder: 4 file(s)") for line in lines)
    assert any("zz-odd.yaml: tuned as one object" in line for line in lines)
    assert any("filter_x_dir" in line for line in lines if "folder#2" in line)
    decisions = result.decisions
    group = decisions[decisions["task"] == "folder"].iloc[0]
    assert group["object"] == "template over 4 objects"
    assert group["n"] == 40  # 10 seeds on each of 4 objects, paired across racers
    assert group["verdict"] == "switch", group["reason"]
    assert json.loads(group["approach"]) == ["downward", 170.0]
    assert group["gain_lo"] > 0
    assert set(decisions["verdict"]) <= set(VERDICTS)
    objects = pd.read_csv(out / "tune" / "objects.csv")
    assert sorted(objects["task"]) == sorted(f.stem for f in files)
    assert set(objects["template_n"]) == {10} and set(objects["current_n"]) == {10}
    tested = objects[objects["exception"].fillna("").astype(str) != ""]
    assert set(tested["exception"]) <= {"override", "tested, not confirmed"}
    # --write: the group's files carry the template, only their filter lines changed
    written = {p.name: p for p in (tmp_path / "written").glob("*.yaml")}
    assert {f.name for f in files} <= set(written)
    for name, path in written.items():
        changed = _changed((folder / name).read_text(), path.read_text())
        assert all(c.startswith(("filter_z_dir", "filter_x_dir")) for c in changed), changed
        if name != odd.name:  # the group switched: every file's approach line changed
            assert 'filter_z_dir: ["downward", 90]' in changed
    tuned = (out / "tune" / "tuned.yaml").read_text()
    assert f"# the template (at {PICK_PATH} of every file of the group):" in tuned
    assert (out / "tune" / "objects_folder.png").is_file()
    # exceptions on real episodes: own best against the broad template, Holm over the two
    screen = RunDir(out / "screen")
    sweep = screen.load_sweep()
    tasks = load_sweep_tasks(sweep, screen.sweep_yaml)
    broad_setting = (str(group["current_approach"]), str(group["current_facing"]))
    narrow = (str(group["approach"]), str(group["facing"]))
    ball, tin = "ball-ball_r2p5", "can-can_r2_h6"
    tests = [
        ExceptionTest("folder", name, "{}", Racer(broad_setting, 0), Racer(narrow, 1))
        for name in (ball, tin)
    ]
    log = run_exceptions(
        tmp_path / "exceptions", sweep, tasks, tests, options, backend="process", workers=2,
        may_run=True,
    )  # fmt: skip
    assert log.episodes == 2 * 2 * 8 and not log.interrupted
    by_name = {t.task: t for t in tests}
    assert by_name[ball].confirmed, (by_name[ball].best.outcomes, by_name[ball].p_holm)
    assert not by_name[tin].confirmed, (by_name[tin].best.outcomes, by_name[tin].p_holm)
