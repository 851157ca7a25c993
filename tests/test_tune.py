"""``harness tune``, ``harness grasps audit`` and ``harness compare`` on real episodes.

The fast tests share one tiny tune (fr3, approach {90, current 140} x facing {current 90, 180},
3 episodes per setting) and assert relations derived at test time from its rows: the
success map counts the rows, the tuned block holds the best setting in fr3's keys and loads as a
task file and as an InternDataEngine file, the McNemar test counts the paired seeds.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from harness.cli import main as cli_main
from harness.config import load_task
from harness.interndata import load_interndata_tasks
from harness.report import compare_runs
from harness.report.stats import mcnemar_exact, wilson_interval
from harness.report.tables import load_episodes
from harness.robots.facts import max_jaw_opening
from harness.tuning.analysis import POOLED
from harness.tuning.audit import audit_run
from harness.tuning.grid import approach_values, facing_values
from harness.tuning.run import tune

ROOT = Path(__file__).resolve().parents[1]
FR3 = ROOT / "tasks" / "pick" / "fr3.yaml"
INTERNDATA = ROOT.parent / "shared" / "datasets" / "interndata-examples"
EPISODES = 3


@pytest.fixture(scope="module")
def tuned(tmp_path_factory: pytest.TempPathFactory):
    out = tmp_path_factory.mktemp("tune") / "run"
    return tune([FR3], episodes=EPISODES, step=90, bands=0, out=out, backend="serial")


def test_grid_holds_both_angle_forms_and_valid_bands() -> None:
    approach = approach_values(5, 3)
    assert [a[1] for a in approach[:18]] == [float(a) for a in range(90, 180, 5)]  # 90..175
    assert approach[18:] == [["downward", 90.0, 120.0], ["downward", 120.0, 150.0],
                             ["downward", 150.0, 180.0]]  # fmt: skip
    facing = facing_values(5, 2)
    assert facing[-3] == ["forward", 180.0] and facing[-2:] == [
        ["forward", 90.0, 0.0],
        ["forward", 180.0, 90.0],
    ]


def test_mcnemar_exact_on_hand_counts() -> None:
    assert mcnemar_exact(0, 3).p_value == pytest.approx(2 / 8)  # P(B(3,.5) in {0,3})
    assert mcnemar_exact(1, 6).p_value == pytest.approx(2 * 8 / 128)  # 2 P(B(7,.5) <= 1)
    assert mcnemar_exact(6, 1).p_value == pytest.approx(2 * 8 / 128)
    assert mcnemar_exact(5, 5).p_value == 1.0
    assert mcnemar_exact(0, 0).p_value == 1.0
    with pytest.raises(ValueError):
        mcnemar_exact(-1, 2)


def test_wilson_known_values() -> None:
    z2 = 1.959963984540054**2
    assert wilson_interval(0, 3) == pytest.approx((0.0, z2 / (3 + z2)))  # 0.5615
    assert wilson_interval(3, 3) == pytest.approx((3 / (3 + z2), 1.0))  # 0.4385


def test_tune_map_counts_the_rows_and_tests_best_against_current(tuned) -> None:
    rows = load_episodes(tuned.run_dir)
    assert len(rows) == 2 * 2 * EPISODES  # approach {90, 140} x facing {90, 180}
    chosen = tuned.choices.set_index("object")
    pooled = chosen.loc[POOLED]
    assert (pooled["current_approach"], pooled["current_facing"]) == (
        '["downward", 140.0]',
        '["forward", 90.0]',
    )
    at = (rows["param.pick.approach_filter"] == pooled["approach"]) & (
        rows["param.pick.facing_filter"] == pooled["facing"]
    )
    assert (pooled["n"], pooled["successes"]) == (EPISODES, int(rows.loc[at, "success"].sum()))
    assert (pooled["lo"], pooled["hi"]) == pytest.approx(
        wilson_interval(int(pooled["successes"]), EPISODES)
    )
    lower = rows.groupby(["param.pick.approach_filter", "param.pick.facing_filter"])["success"]
    best_lower = max(wilson_interval(int(k), EPISODES)[0] for k in lower.sum())
    assert pooled["lo"] == pytest.approx(best_lower) and pooled["lo"] >= pooled["current_lo"]
    assert pooled["pairs"] == EPISODES
    test = mcnemar_exact(int(pooled["only_current"]), int(pooled["only_best"]))
    assert pooled["p_value"] == pytest.approx(test.p_value)
    assert pooled["successes"] - pooled["current_successes"] == (
        pooled["only_best"] - pooled["only_current"]
    )


def test_tune_heatmap_per_robot_arm_object(tuned) -> None:
    assert [p.name for p in tuned.heatmaps] == ["fr3_left_cube.png"]
    assert tuned.heatmaps[0].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "fr3_left_cube.png" in tuned.tuned_md.read_text()


def test_tuned_block_pastes_into_the_task_file(tuned, tmp_path: Path) -> None:
    block = yaml.safe_load(tuned.tuned_yaml.read_text())["fr3"]["left"]["pick"]
    best = tuned.choices.set_index("object").loc[POOLED]
    # fr3 approaches along EE z and faces along EE x (robots/fr3/robot.yaml convention).
    assert block["filter_z_dir"] == json.loads(best["approach"])
    assert block["filter_x_dir"] == json.loads(best["facing"])
    assert not {"approach_filter", "facing_filter", "semantics"} & set(block)
    assert "# tuned:" in tuned.yaml_text and "exact McNemar" in tuned.yaml_text
    task = yaml.safe_load(FR3.read_text())
    task["pick"] = block
    pasted = tmp_path / "fr3_tuned.yaml"
    pasted.write_text(yaml.safe_dump(task, sort_keys=False))
    assert cli_main(["validate", str(pasted)]) == 0
    loaded = load_task(pasted)
    assert loaded.pick.filter_z_dir is not None
    assert loaded.pick.filter_z_dir.as_list() == json.loads(best["approach"])
    original = load_task(FR3).pick.model_dump()
    for key in ("pre_grasp_offset", "post_grasp_offset_max", "lift_th", "test_mode", "t_eps"):
        assert loaded.pick.model_dump()[key] == original[key]


def test_tuned_block_pastes_into_an_interndata_file(tuned, tmp_path: Path) -> None:
    source = INTERNDATA / "tasks" / "franka_single_pick_banana.yaml"
    if not source.is_file():
        pytest.skip("the InternDataEngine example data (../shared) is not here")
    block = yaml.safe_load(tuned.tuned_yaml.read_text())["fr3"]["left"]["pick"]
    data = yaml.safe_load(source.read_text())
    skill = data["tasks"][0]["skills"][0]["franka"][0]["left"][0]
    assert skill["name"] == "pick"
    for key in ("filter_x_dir", "filter_y_dir", "filter_z_dir"):
        skill.pop(key, None)
    skill.update(block)
    pasted = tmp_path / "franka_tuned.yaml"
    pasted.write_text(yaml.safe_dump(data, sort_keys=False))
    bottle = INTERNDATA / "objects" / "recyclable_garbage" / "bottle_0" / "Aligned_obj.usd"
    picks = load_interndata_tasks(pasted, objects={"pick_object_left": str(bottle)},
                                  check_assets=False)  # fmt: skip
    filters = picks[0].task.pick
    assert filters.filter_z_dir is not None and filters.filter_x_dir is not None
    assert filters.filter_z_dir.as_list() == block["filter_z_dir"]
    assert filters.filter_x_dir.as_list() == block["filter_x_dir"]


def test_compare_matches_settings_paired_and_unpaired(tuned, tmp_path: Path, capsys) -> None:
    same_seeds, new_seeds = tmp_path / "same", tmp_path / "new"
    base = ["run", str(FR3), "--episodes", str(EPISODES), "--record", "none", "--out"]
    assert cli_main([*base, str(same_seeds)]) == 0
    assert cli_main([*base, str(new_seeds), "--seed", "7"]) == 0
    # The plain run sets filter_z_dir / filter_x_dir; the tune sets approach / facing filters.
    paired = compare_runs(tuned.run_dir, same_seeds)
    matched = paired[paired["present"] == "both"]
    assert len(matched) == 1 and len(paired) == 4  # the current setting; 3 others in A only
    row = matched.iloc[0]
    assert json.loads(row["settings"])["filter_z_dir"] == ["downward", 140.0]
    assert row["test"] == "mcnemar" and row["pairs"] == EPISODES
    assert row["p_value"] == pytest.approx(
        mcnemar_exact(int(row["only_a"]), int(row["only_b"])).p_value
    )
    unpaired = compare_runs(tuned.run_dir, new_seeds)
    row = unpaired[unpaired["present"] == "both"].iloc[0]
    assert row["test"] in ("z", "fisher") and row["pairs"] == 0
    # The analysis alone, again (after an interrupted and resumed tune); a plain run is refused.
    assert cli_main(["tune", "--analyse", str(tuned.run_dir)]) == 0
    assert "fr3:" in capsys.readouterr().out
    assert cli_main(["tune", "--analyse", str(same_seeds)]) == 2
    assert "not a tune run" in capsys.readouterr().err


def _wide_grasp_task(tmp_path: Path) -> tuple[Path, Path]:
    """fr3 and the box at 1.6x (8 x 12.8 x 22.4 cm) with only its grasps across 12.8 cm, which
    the FR3 jaw (8 cm) cannot close on: whatever the filters pass or the reference falls back
    to, the executed grasp is one of them."""
    generated = tmp_path / "generated.npy"
    mesh = ROOT / "tasks" / "objects" / "box" / "box.obj"
    args = ["grasps", "generate", str(mesh), "--out", str(generated), "-n", "200"]
    assert cli_main([*args, "--scale", "1.6", "--max-width", "0.15"]) == 0
    grasps = np.load(generated)
    wide = grasps[:, 1] > max_jaw_opening("fr3") + 0.02
    assert wide.sum() >= 20
    ordered = tmp_path / "grasps.npy"
    np.save(ordered, grasps[wide])
    task = yaml.safe_load(FR3.read_text())
    task["name"] = "fr3_pick_big_box"
    task["objects"] = [{"name": "box", "mesh": "box", "scale": 1.6, "grasps": str(ordered)}]
    path = tmp_path / "task.yaml"
    path.write_text(yaml.safe_dump(task, sort_keys=False))
    return path, ordered


def test_audit_flags_a_grasp_wider_than_the_jaw(tmp_path: Path) -> None:
    task, grasp_file = _wide_grasp_task(tmp_path)
    run = tmp_path / "run"
    cli = ["run", str(task), "--episodes", "4", "--record", "none", "--out", str(run)]
    assert cli_main(cli) == 0
    result = audit_run(run, min_trials=1)
    table = result.table
    executed = load_episodes(run)
    assert table["trials"].sum() == (executed["chosen_index"] >= 0).sum()
    flagged = table[table["flagged"]]
    jaw = max_jaw_opening("fr3")
    wide = flagged[flagged["causes"].str.contains("wider than the jaw")]
    assert len(wide) >= 1 and (wide["width_m"] > jaw).all()
    assert (flagged["successes"] == 0).all()
    original = np.load(grasp_file)
    cleaned = np.load(result.cleaned[str(grasp_file)])
    assert cleaned.shape == (len(original) - len(flagged), 17)
    kept = np.delete(original, flagged["grasp_row"].to_numpy(), axis=0)
    assert np.array_equal(cleaned, kept)
    assert cli_main(["grasps", "audit", str(run), "--min-trials", "1"]) == 0
    assert pd.read_csv(result.csv)["flagged"].sum() == len(flagged)


@pytest.mark.slow
def test_tuned_rate_on_fresh_seeds_lies_in_its_interval(tmp_path: Path) -> None:
    """Tune the canonical fr3 and Split ALOHA left tasks (10 episodes per setting), paste each
    tuned block into its task file and run it on 20 fresh seeds (another sweep seed): the fresh
    rate lies within the tune's 95% interval."""
    tasks = {("fr3", "left"): FR3, ("split_aloha", "left"): FR3.parent / "split_aloha_left.yaml"}
    result = tune(list(tasks.values()), episodes=10, step=45, bands=0, out=tmp_path / "tune")
    blocks = yaml.safe_load(result.tuned_yaml.read_text())
    chosen = result.choices[result.choices["object"] == POOLED].set_index(["robot", "arm"])
    for (robot, arm), path in tasks.items():
        task = yaml.safe_load(path.read_text())
        task["pick"] = blocks[robot][arm]["pick"]
        pasted = tmp_path / f"{robot}_{arm}.yaml"
        pasted.write_text(yaml.safe_dump(task, sort_keys=False))
        assert cli_main(["validate", str(pasted)]) == 0
        out = tmp_path / f"fresh_{robot}"
        args = ["run", str(pasted), "--episodes", "20", "--seed", "424242", "--record", "none"]
        assert cli_main([*args, "--out", str(out)]) == 0
        fresh = load_episodes(out)
        assert not set(fresh["seed"]) & set(load_episodes(result.run_dir)["seed"])
        rate = float(fresh["success"].mean())
        best = chosen.loc[(robot, arm)]
        assert best["lo"] <= rate <= best["hi"], (robot, rate, best["lo"], best["hi"])


def test_settings_pair_within_the_other_swept_keys() -> None:
    """A sweep file's other axes (object.mesh) split the pairs: the same seed of cube and banana
    is not a pair."""
    from harness.tuning.analysis import paired_counts, settings_frame

    rows = []
    for mesh, ok_best, ok_current in (("cube", True, False), ("banana", False, True)):
        for setting, ok in (("best", ok_best), ("current", ok_current)):
            rows.append(
                {
                    "robot": "fr3",
                    "arm": "left",
                    "object": mesh,
                    "task": "t",
                    "seed": 7,
                    "point_id": 0,
                    "success": ok,
                    "valid": False,
                    "param.pick.approach_filter": setting,
                    "param.pick.facing_filter": "f",
                    "param.object.mesh": mesh,
                }
            )
    settings = settings_frame(pd.DataFrame(rows), "reference")
    assert paired_counts(settings, ("best", "f"), ("current", "f")) == (2, 1, 1)
    assert not settings_frame(pd.DataFrame(rows), "valid")["ok"].any()
