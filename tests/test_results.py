"""The episode row schema and the append-only store: typing, crash tolerance, dedup, export."""

from __future__ import annotations

import json
import math
import typing
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from harness.errors import HarnessError
from harness.failures import FAILURE_REASONS
from harness.row import empty_row
from harness.runs.store import (
    SCHEMA,
    ResultStore,
    read_episodes_csv,
    typed_frame,
)

# The columns the episode row must have (issue 7 / the brief), in their documented types.
DOCUMENTED = {
    "str": "episode_id run point task robot arm object semantics test_mode timing filter_x_dir "
    "filter_y_dir filter_z_dir approach_filter facing_filter direction_to_obj filter_outcome "
    "candidate_failures planning_world "
    "failure_reason error_message harness_version mujoco_version",
    "int": "point_id seed episode_index n_total n_passed_filter n_feasible n_tested chosen_index "
    "sim_steps",
    "float": "pre_grasp_offset post_grasp_offset chosen_score approach_angle_deg ik_time_s "
    "plan_time_s traj_duration_s sim_time_s wall_time_s finger_force_left_n finger_force_right_n "
    "lift_height_m slip_m max_joint_vel max_object_vel tcp_grasp_error_m object_friction "
    "speed_scale hold_rotation_rad object_mass_kg",
    "bool": "success",
}


def row(episode_id: str, **values) -> dict:
    return {"episode_id": episode_id, "run": "t", "robot": "fr3", **values}


def test_schema_has_every_documented_column_with_its_type() -> None:
    for dtype, names in DOCUMENTED.items():
        for name in names.split():
            assert SCHEMA[name].dtype == dtype, name
    assert SCHEMA["chosen_index"].null_value == -1
    assert math.isnan(SCHEMA["tcp_grasp_error_m"].null_value)
    assert SCHEMA["direction_to_obj"].null_value == ""
    assert all(column.description for column in SCHEMA.values())


def test_schema_matches_the_episode_row_and_the_failure_taxonomy() -> None:
    from harness.config import TaskConfig
    from harness.episode import EpisodeSpec, base_row
    from harness.failures import FailureReason

    task = TaskConfig(robot="fr3", objects=[{"name": "cube", "mesh": "cube"}])
    produced = base_row(EpisodeSpec(task=task, point={"pick.pre_grasp_offset": 0.08}))
    assert set(produced) - set(SCHEMA) == {"param.pick.pre_grasp_offset"}
    assert set(typing.get_args(FailureReason)) - {""} == set(FAILURE_REASONS)


def test_episode_row_and_error_row_share_one_identity() -> None:
    from dataclasses import fields

    from harness.config import TaskConfig
    from harness.episode import EpisodeSpec, base_row
    from harness.row import IDENTITY_COLUMNS, EpisodeRow
    from harness.runs.worker import error_row

    assert [f.name for f in fields(EpisodeRow)] == list(SCHEMA)
    task = TaskConfig(robot="fr3", objects=[{"name": "cube", "mesh": "cube"}])
    spec = EpisodeSpec(task=task, seed=7, point={"pick.approach_filter": ["downward", 140]})
    produced = base_row(spec)
    lost = error_row(spec, "worker crashed")
    identity = [*IDENTITY_COLUMNS, "param.pick.approach_filter"]
    assert {k: produced[k] for k in identity} == {k: lost[k] for k in identity}
    assert produced["param.pick.approach_filter"] == '["downward", 140]'
    assert produced["episode_id"] == spec.resolved_id and produced["seed"] == 7
    assert list(produced)[: len(SCHEMA) - 4] == list(SCHEMA)[:-4]  # executor/store columns unset


def test_append_and_load_round_trip_with_types_and_nulls(tmp_path: Path) -> None:
    store = ResultStore(tmp_path / "run")
    store.append(
        row(
            "a",
            success=np.bool_(True),
            n_total=np.int64(6000),
            lift_height_m=np.float32(0.25),
            chosen_score=float("nan"),
            **{"param.pick.approach_filter": json.dumps(["downward", 140]), "param.obj.mass": 0.1},
        )
    )
    store.append(row("b", failure_reason="dropped", **{"param.obj.mass": 0.2}))
    frame = store.load()
    assert list(frame["episode_id"]) == ["a", "b"]
    assert frame["success"].tolist() == [True, False]
    assert frame["n_total"].tolist() == [6000, 0]
    assert frame["lift_height_m"].iloc[0] == 0.25
    assert math.isnan(frame["lift_height_m"].iloc[1])
    # Missing columns get the schema's null value.
    assert frame["chosen_index"].tolist() == [-1, -1]
    assert frame["direction_to_obj"].tolist() == ["", ""]
    assert frame["failure_reason"].tolist() == ["", "dropped"]
    for name, column in SCHEMA.items():
        kind = frame[name].dtype.kind
        assert kind == {"str": "O", "int": "i", "float": "f", "bool": "b"}[column.dtype] or (
            column.dtype == "str" and pd.api.types.is_string_dtype(frame[name])
        ), name
    # Dynamic parameter columns: numbers stay numbers, lists stay JSON strings.
    assert frame["param.obj.mass"].tolist() == [0.1, 0.2]
    assert frame["param.pick.approach_filter"].tolist() == ['["downward", 140]', ""]
    assert list(frame.columns[: len(SCHEMA)]) == list(SCHEMA)
    assert store.completed_ids() == {"a", "b"}


def test_truncated_last_line_is_tolerated_and_the_next_row_starts_clean(tmp_path: Path) -> None:
    store = ResultStore(tmp_path)
    store.append(row("a", success=True))
    store.append(row("b"))
    # A crash in the middle of writing the third row.
    with open(store.path, "a", encoding="utf-8") as handle:
        handle.write('{"episode_id": "c", "robot": "fr')
    crashed = ResultStore(tmp_path)
    assert crashed.completed_ids() == {"a", "b"}
    assert crashed.skipped_lines == [3]
    assert len(crashed.load()) == 2
    # The resumed run appends; its row must not be glued onto the torn line.
    crashed.append(row("c", success=True))
    resumed = ResultStore(tmp_path)
    assert resumed.completed_ids() == {"a", "b", "c"}
    assert resumed.load().set_index("episode_id").loc["c", "success"]
    assert resumed.skipped_lines == [3]


def test_a_second_load_of_unchanged_rows_is_the_same_frame_and_sees_every_change(
    tmp_path: Path,
) -> None:
    """A sweep's export and its report read the same rows: the second load comes from the
    first's parse, as an equal frame of its own; any change of the file's bytes (an appended
    row, a row rewritten to the same length, a torn line) is read again."""
    store = ResultStore(tmp_path)
    store.append(row("a", success=True))
    store.append(row("b"))
    first = store.load()
    second = ResultStore(tmp_path).load()
    pd.testing.assert_frame_equal(first, second)
    second.loc[0, "success"] = False  # the caller's copy: the next load is unaffected
    assert bool(ResultStore(tmp_path).load().loc[0, "success"])
    text = store.path.read_text(encoding="utf-8")
    store.path.write_text(text.replace('"success": true', '"success": fals'), encoding="utf-8")
    rewritten = ResultStore(tmp_path)
    assert len(rewritten.load()) == 1 and rewritten.skipped_lines == [1]  # same size, now torn
    store.path.write_text(text, encoding="utf-8")
    store.append(row("c", success=True))
    again = ResultStore(tmp_path)
    assert list(again.load()["episode_id"]) == ["a", "b", "c"] and again.skipped_lines == []


def test_duplicate_episode_ids_keep_the_last_row(tmp_path: Path) -> None:
    store = ResultStore(tmp_path)
    store.append(row("a", failure_reason="error", error_message="worker crashed"))
    store.append(row("b", success=True))
    store.append(row("a", success=True))
    frame = store.load().set_index("episode_id")
    assert len(frame) == 2
    assert frame.loc["a", "success"]
    assert frame.loc["a", "failure_reason"] == ""


def test_export_round_trips_through_csv_and_parquet(tmp_path: Path) -> None:
    store = ResultStore(tmp_path)
    rng = np.random.default_rng(0)
    for index in range(12):
        ok = bool(index % 3)
        store.append(
            row(
                f"e{index}",
                point_id=index % 3,
                point=json.dumps({"pick.filter_z_dir": ["downward", 120 + 10 * (index % 3)]}),
                seed=1000 + index,
                success=ok,
                failure_reason="" if ok else "no_contact",
                error_message="" if ok else 'the "finger", missed, twice',
                lift_height_m=float(rng.uniform(0, 0.1)) if ok else float("nan"),
                n_total=6000,
                **{"param.pick.filter_z_dir": json.dumps(["downward", 120 + 10 * (index % 3)])},
            )
        )
    csv_path, parquet_path = store.export()
    loaded = store.load()
    pd.testing.assert_frame_equal(read_episodes_csv(csv_path), loaded)
    pd.testing.assert_frame_equal(pd.read_parquet(parquet_path), loaded)
    # A run directory holding only the exported files loads the same.
    store.path.unlink()
    pd.testing.assert_frame_equal(ResultStore(tmp_path).load(), loaded)
    (tmp_path / "episodes.parquet").unlink()
    pd.testing.assert_frame_equal(ResultStore(tmp_path).load(), loaded)
    assert ResultStore(tmp_path).completed_ids() == set(loaded["episode_id"])


def test_empty_store_and_bad_input(tmp_path: Path) -> None:
    store = ResultStore(tmp_path / "nothing")
    assert store.completed_ids() == set()
    assert store.load().empty
    assert not store.exists()
    with pytest.raises(ValueError, match="episode_id"):
        store.append({"robot": "fr3"})
    not_episodes = tmp_path / "other.csv"
    not_episodes.write_text("a,b\n1,2\n", encoding="utf-8")
    with pytest.raises(HarnessError, match=r"other\.csv.*episode_id"):
        read_episodes_csv(not_episodes)
    bad = tmp_path / "bad.csv"
    bad.write_text("episode_id,n_total\nx,many\n", encoding="utf-8")
    with pytest.raises(HarnessError, match=r"bad\.csv.*'n_total'"):
        read_episodes_csv(bad)


def test_empty_row_and_typed_frame_of_partial_rows() -> None:
    blank = empty_row()
    assert set(blank) == set(SCHEMA)
    frame = typed_frame([{"episode_id": "x", "success": "True", "n_total": "12", "seed": 3.0}])
    assert frame.loc[0, "success"]
    assert frame.loc[0, "n_total"] == 12 and frame.loc[0, "seed"] == 3
    assert frame.loc[0, "point"] == "{}"


def test_63_bit_seeds_survive_csv_and_parquet_exactly(tmp_path: Path) -> None:
    """Episode seeds are 63-bit: a float64 detour would change them and break replays."""
    seeds = [6569863346532939966, (1 << 63) - 1, 0]
    store = ResultStore(tmp_path)
    for index, seed in enumerate(seeds):
        store.append(row(f"s{index}", seed=seed))
    csv_path, parquet_path = store.export()
    assert store.load()["seed"].tolist() == seeds
    assert read_episodes_csv(csv_path)["seed"].tolist() == seeds
    assert pd.read_parquet(parquet_path)["seed"].tolist() == seeds
