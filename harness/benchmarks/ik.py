"""Benchmark section ``ik``: IK feasibility checks per second and their success rate.

One check = what ``test_mode: ik`` does per pose: a placo whole-body IK solve from the arm's
home (default settings: 5 mm / 0.05 rad acceptance, tight convergence, random restarts).
Reachable targets are the EE poses of random in-limit configurations (the lift at home);
unreachable ones are the same poses moved 1.5 m away from the robot. Unreachable checks are the
expensive ones (every restart runs to its stall test), so both rates are reported.
"""

from __future__ import annotations

import time

import numpy as np

from harness.benchmarks.framework import Figure, figure, rate_figure
from harness.benchmarks.machine import one_core
from harness.planning.arm_ik import arm_ik
from harness.planning.ik import IKSettings, WholeBodyIK
from harness.robots import RobotModel, available_robots
from harness.robots.facts import robot_arms

SECTION = "ik"
FAR = np.array([1.5, 1.5, 0.0])


def _targets(ik: WholeBodyIK, home: np.ndarray, count: int, seed: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    targets = []
    for _ in range(count):
        q = rng.uniform(ik.lower, ik.upper)
        if ik.lift_joint is not None:
            q[0] = home[0]
        targets.append(ik.fk(q))
    return targets


def _checks(
    ik: WholeBodyIK, home: np.ndarray, targets: list[np.ndarray], seed: int
) -> tuple[list[float], int]:
    rng = np.random.default_rng(seed)
    settings = IKSettings()
    times, solved = [], 0
    for target in targets:
        start = time.perf_counter()
        result = ik.solve(target, home, rng, settings)
        times.append(time.perf_counter() - start)
        solved += result.success
    return times, solved


def _batch_rates(times: list[float], batch: int) -> list[float]:
    """Checks per second over consecutive batches of ``batch`` checks (the last may be short)."""
    return [
        len(chunk) / sum(chunk)
        for chunk in (times[i : i + batch] for i in range(0, len(times), batch))
        if sum(chunk) > 0
    ]


def measured_arms() -> list[tuple[str, str]]:
    """Every bundled robot (the registry's list) with its first arm."""
    return [(name, robot_arms(name)[0]) for name in available_robots()]


def run(quick: bool) -> list[Figure]:
    with one_core() as pinned:
        return _figures(quick, pinned)


def _figures(quick: bool, pinned: str) -> list[Figure]:
    count = 40 if quick else 300
    batch = 10
    figures: list[Figure] = []
    for name, arm in measured_arms():
        ik, home = arm_ik(RobotModel.load(name), arm)
        reachable = _targets(ik, home, count, seed=1)
        unreachable = []
        for T in reachable[: max(20, count // 4)]:
            far = T.copy()
            far[:3, 3] += FAR
            unreachable.append(far)
        for label, targets in (("reachable", reachable), ("unreachable", unreachable)):
            times, solved = _checks(ik, home, targets, seed=2)
            rate = solved / len(targets)
            per_check_ms = 1e3 * float(np.median(times))
            figures.append(
                figure(
                    SECTION,
                    f"{name} {arm}: IK checks/s, {label} targets",
                    _batch_rates(times, batch),
                    "checks/s",
                    higher_is_better=True,
                    notes=f"{len(targets)} checks in batches of {batch}; median check "
                    f"{per_check_ms:.2f} ms, overall {len(times) / sum(times):.0f}/s; {pinned}",
                    extra={
                        "checks_per_s_overall": len(times) / sum(times),
                        "check_ms_median": per_check_ms,
                        "check_ms_p90": 1e3 * float(np.quantile(times, 0.9)),
                        "n": len(targets),
                        "active_joints": list(ik.joint_names),
                    },
                )
            )
            figures.append(
                rate_figure(
                    SECTION,
                    f"{name} {arm}: IK success, {label} targets",
                    solved,
                    len(targets),
                    notes=f"{solved}/{len(targets)} ({rate:.0%})"
                    + ("; FK of in-limit configurations" if label == "reachable" else "")
                    + ("; 1.5 m out of reach, must fail" if label == "unreachable" else ""),
                )
            )
    return figures
