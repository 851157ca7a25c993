"""The batch judge's one-pass walk (``harness.engines.mjwarp.judge._Judge.motion``) against the CPU
loop's row-by-row walk it replaced, on real FR3 jobs with synthetic signal rows: unstable rows
(NaN, runaway speeds, an escaped object), failing closings, timeouts, everywhere."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
import pytest
from helpers import fr3_device_jobs

from harness.engines.mjwarp.judge import _Judge
from harness.engines.mjwarp.signals import (
    EE_MAT,
    JOINT_SPEED,
    MAX_QVEL,
    NONFINITE,
    OBJ_MAT,
    OBJ_POS,
    PENETRATION,
    SIGNALS,
    TCP_MAT,
    object_speed,
    unstable_reason,
)
from harness.pick.verdict import first_failure


class _LoopJudge(_Judge):
    """The row-by-row walk the batch judge had (the oracle). The measurements at the closing
    and at the end of the list are the judge's own (``closing``, ``finish``): the walk's order
    and where it stops are what is compared."""

    def motion(self) -> bool:
        out, schedule, steps = self.out, self.schedule, self.steps
        last = schedule.verdict_step if schedule.verdict_step >= 0 else schedule.steps - 1
        out.object_z_before = math.nan
        reached = False
        step = 0
        for step in range(last + 1):
            row = steps[step]
            out.max_joint_vel = max(out.max_joint_vel, float(row[JOINT_SPEED]))
            out.max_object_vel = max(out.max_object_vel, object_speed(row))
            out.table_penetration_m = max(out.table_penetration_m, float(row[PENETRATION]))
            reason = unstable_reason(row)
            if reason is not None:
                out.failure_reason, out.message = "sim_unstable", reason
                break
            if step == schedule.close_step and self.closing(row):
                break
            if step == schedule.verdict_step:
                self.measure(row)
                if not self.job.semantics.hold_after_list:
                    self.fail(first_failure(self.job.semantics.verdict_terms(self.pick, out)))
                reached = True
        return self.finish(step, reached)


@pytest.fixture(scope="module")
def jobs() -> list[Any]:
    return fr3_device_jobs(2)


def _rows(rng: np.random.Generator, job: Any, n: int) -> np.ndarray:
    rows = np.zeros((n, SIGNALS), dtype=np.float32)
    rows[:, :2] = rng.choice([0.0, 0.2, 3.0, 40.0], size=(n, 2))  # finger forces
    rows[:, OBJ_POS] = job.object_init_position + rng.normal(0, 0.05, (n, 3))
    rows[:, 5:8] = rng.normal(0, 0.3, (n, 3))  # object velocity
    rows[:, JOINT_SPEED] = rng.uniform(0, 3, n)
    rows[:, PENETRATION] = rng.uniform(0, 0.004, n)
    rows[:, MAX_QVEL] = rng.uniform(0, 5, n)
    for mat in (EE_MAT, TCP_MAT, OBJ_MAT):
        rows[:, mat] = np.eye(3, dtype=np.float32).ravel()
    for _ in range(rng.integers(0, 3)):  # unstable rows of each kind
        k = rng.integers(0, n)
        kind = rng.integers(0, 4)
        if kind == 0:
            rows[k, JOINT_SPEED] = np.nan
        elif kind == 1:
            rows[k, MAX_QVEL] = 1e6
        elif kind == 2:
            rows[k, OBJ_POS.start + 2] = -50.0
        else:
            rows[k, NONFINITE] = 1.0
    return rows


def test_the_one_pass_walk_equals_the_row_by_row_walk(jobs: list[Any]) -> None:
    rng = np.random.default_rng(7)
    for trial in range(300):
        job = jobs[trial % len(jobs)]
        n = int(rng.integers(5, 60))
        close = int(rng.integers(-1, n))
        verdict = int(rng.choice([-1, rng.integers(max(close, 0), n)]))
        schedule = dataclasses.replace(
            job.schedule,
            ctrl=job.schedule.ctrl[:1].repeat(n, axis=0),
            close_step=close,
            verdict_step=verdict,
        )
        job = dataclasses.replace(job, schedule=schedule)
        steps = _rows(rng, job, n)
        new, old = _Judge(job, schedule, steps), _LoopJudge(job, schedule, steps)
        assert new.motion() == old.motion(), trial
        a, b = dataclasses.asdict(new.out), dataclasses.asdict(old.out)
        for key in a:
            x, y = a[key], b[key]
            if isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
                np.testing.assert_array_equal(x, y, err_msg=f"{trial} {key}")
            elif key == "max_object_vel":  # float32 norms: row by row or in one call
                assert math.isclose(x, y, rel_tol=1e-6), (trial, key)
            elif isinstance(x, float) and math.isnan(x):
                assert isinstance(y, float) and math.isnan(y), (trial, key)
            else:
                assert x == y, (trial, key, x, y)
