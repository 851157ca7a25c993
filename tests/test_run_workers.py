"""``harness run --workers N``: the episodes of one task on a process pool, the same rows as
in one process."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from helpers import PROJECT_ROOT, harness

COMPARED = ["episode_id", "seed", "success", "failure_reason", "chosen_index", "lift_height_m"]


@pytest.mark.slow
def test_run_with_two_workers_gives_the_rows_of_one(tmp_path: Path) -> None:
    task = PROJECT_ROOT / "tasks" / "pick" / "fr3.yaml"
    tables = []
    for workers in ("1", "2"):
        out = tmp_path / f"w{workers}"
        done = harness(
            "run", task, "--episodes", "2", "--workers", workers, "--record", "none",
            "--out", out,
        )  # fmt: skip
        assert done.returncode == 0, done.stderr
        table = pd.read_csv(out / "episodes.csv").sort_values("episode_id")
        tables.append(table[COMPARED].reset_index(drop=True))
    assert len(tables[0]) == 2
    pd.testing.assert_frame_equal(tables[0], tables[1])


def test_run_rejects_zero_workers() -> None:
    done = harness("run", "tasks/pick/fr3.yaml", "--workers", "0")
    assert done.returncode != 0
    assert "--workers" in done.stderr
