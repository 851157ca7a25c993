"""The lean CPU pipeline (issue 24): the parent's per-row costs and the validity phase skipped
where nothing reads it.

- the episode store hands every row to the operating system at once but fsyncs at most once per
  ``SYNC_EVERY_S`` (and at the export), so a crash of the driver loses nothing written;
- a tune under ``--objective reference`` runs its tasks with ``validity: off`` (strict keeps the
  phase: it is its verdict); those rows say the phase did not run, their reference columns are
  those of the same episode with the phase, and the candidate cache never reuses an execution
  made without the phase for a task that has it;
- the valid objective refuses rows without the phase instead of rating every setting 0;
- the preflight checks each task physics once, not once per filter setting.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pandas as pd
import pytest

from harness.config import apply_overrides, load_task
from harness.episode import EpisodeSpec, run_episode
from harness.episode.candidate_cache import WALL_TIME_COLUMNS, CandidateCache, evaluation_key
from harness.errors import HarnessError
from harness.runs import preflight, store
from harness.runs.preflight import check_tasks
from harness.runs.store import ResultStore
from harness.tuning.analysis import check_validity_ran
from harness.tuning.grid import objective_tasks

ROOT = Path(__file__).resolve().parents[1]
VALIDITY_COLUMNS = ("valid", "invalid_reason", "robustness_g", "hold_slip_m",
                    "hold_rotation_rad", "min_finger_force_n")  # fmt: skip


def _row(i: int) -> dict[str, Any]:
    return {"episode_id": f"e{i}", "success": bool(i % 2), "failure_reason": ""}


def test_rows_are_written_at_once_and_fsynced_at_most_once_a_second(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    clock = [100.0]
    synced: list[int] = []
    monkeypatch.setattr(store.time, "monotonic", lambda: clock[0])
    monkeypatch.setattr(store.os, "fsync", lambda fd: synced.append(fd))
    results = ResultStore(tmp_path)
    for i in range(50):
        results.append(_row(i))
    assert synced == []  # within the second: written, not yet synced
    assert [r["episode_id"] for r in ResultStore(tmp_path).rows()] == [f"e{i}" for i in range(50)]
    clock[0] += store.SYNC_EVERY_S
    results.append(_row(50))
    assert len(synced) == 1  # the second is up: this row's append syncs the file
    results.append(_row(51))
    assert len(synced) == 1
    results.export()  # the end of a run: everything synced before the export
    assert len(synced) == 2
    results.sync()  # nothing new: no further fsync
    assert len(synced) == 2
    assert len(pd.read_csv(tmp_path / store.CSV_NAME)) == 52


def test_a_reference_objective_switches_the_phase_off_only_where_allowed() -> None:
    fr3 = load_task(ROOT / "tasks" / "pick" / "fr3.yaml")
    strict = apply_overrides(fr3, {"pick.semantics": "strict"})
    assert fr3.pick.validity
    assert objective_tasks([fr3, strict], "valid") == [fr3, strict]
    plain, kept = objective_tasks([fr3, strict], "reference")
    assert not plain.pick.validity and plain.source == fr3.source
    assert kept is strict  # strict's verdict is the phase
    # a task with the phase and one without never share an evaluation
    assert evaluation_key(plain, 3) != evaluation_key(fr3, 3)


def test_rows_without_the_phase_say_so_and_are_never_shared_with_rows_that_need_it() -> None:
    fr3 = load_task(ROOT / "tasks" / "pick" / "fr3.yaml")
    (off,) = objective_tasks([fr3], "reference")
    scenes: dict[Any, Any] = {}
    cache = CandidateCache()
    seeds = (0, 1, 2)
    with_phase = [run_episode(EpisodeSpec(task=fr3, seed=s), scenes, cache).row for s in seeds]
    executed = cache.stats.outcomes
    without = [run_episode(EpisodeSpec(task=off, seed=s), scenes, cache).row for s in seeds]
    # every execution ran again for the task without the phase: none was answered from the
    # executions made with it
    assert cache.stats.outcomes == 2 * executed > 0
    assert cache.stats.outcome_hits == 0
    assert any(r["success"] for r in with_phase)
    for on_row, off_row in zip(with_phase, without, strict=True):
        assert off_row["valid"] is False and off_row["invalid_reason"] == ""
        for name in VALIDITY_COLUMNS[2:]:
            assert math.isnan(off_row[name]), name
        for name, value in on_row.items():  # the reference columns are untouched by the phase
            if name in VALIDITY_COLUMNS or name in WALL_TIME_COLUMNS:
                continue
            other = off_row[name]
            same = value == other or (
                isinstance(value, float) and math.isnan(value) and math.isnan(other)
            )
            assert same, (name, value, other)
    # an unshared run of the task without the phase gives the same rows
    alone = [run_episode(EpisodeSpec(task=off, seed=s), scenes).row for s in seeds]
    for shared_row, alone_row in zip(without, alone, strict=True):
        for name, value in alone_row.items():
            if name in WALL_TIME_COLUMNS:
                continue
            other = shared_row[name]
            assert value == other or (value != value and other != other), name


def test_the_valid_objective_refuses_rows_without_the_phase() -> None:
    judged = pd.DataFrame(
        {"valid": [True, False], "invalid_reason": ["", "dropped_in_hold"], "success": [1, 1]}
    )
    check_validity_ran(judged)  # every row judged: fine
    skipped = pd.DataFrame({"valid": [False, True], "invalid_reason": ["", ""], "success": [1, 1]})
    with pytest.raises(HarnessError, match="1 of 2 episodes ran without the validity phase"):
        check_validity_ran(skipped)


def test_the_preflight_checks_each_task_physics_once(monkeypatch: pytest.MonkeyPatch) -> None:
    fr3 = load_task(ROOT / "tasks" / "pick" / "fr3.yaml")
    tasks = [
        apply_overrides(fr3, {"pick.filter_z_dir": ["downward", a]}) for a in (100, 120, 140, 160)
    ]
    tasks.append(apply_overrides(fr3, {"pick.max_slip": 0.02}))  # other physics: its own check
    checked: list[Any] = []
    monkeypatch.setattr(preflight, "check_task", lambda task: checked.append(task) or [])
    check_tasks(tasks)
    assert checked == [tasks[0], tasks[4]]


def test_the_end_to_end_bench_sweeps_the_loop_grid_and_compares_outcome_columns() -> None:
    from harness.benchmarks.sharing import APPROACH_DEG, FACING_DEG, _comparable, sweep_document
    from harness.config import SweepConfig
    from harness.runs.expansion import sweep_points

    sweep = SweepConfig.model_validate(sweep_document("fr3", seeds=3, sweep_seed=5))
    assert (sweep.episodes_per_point, sweep.seed, sweep.record) == (3, 5, "none")
    assert len(sweep_points(sweep)) == len(APPROACH_DEG) * len(FACING_DEG) == 342
    row = {"episode_id": "x", "point_id": 4, "seed": 9, "wall_time_s": 0.2, "success": True,
           "param.pick.approach_filter": "[1]", "robustness_g": float("nan")}  # fmt: skip
    kept = _comparable(row)
    assert set(kept) == {"success", "robustness_g"} and math.isnan(kept["robustness_g"])
