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

from harness.bench import Figure, figure
from harness.planning.ik import IKSettings, WholeBodyIK
from harness.robot import RobotModel

SECTION = "ik"
ARMS = (("fr3", "left"), ("split_aloha", "left"), ("lift2", "left"))
FAR = np.array([1.5, 1.5, 0.0])


def _solver(name: str, arm: str) -> tuple[WholeBodyIK, np.ndarray]:
    robot = RobotModel.load(name)
    spec = robot.arm(arm)
    active = ([robot.lift_joint] if robot.lift_joint else []) + list(spec.joints)
    ik = WholeBodyIK(robot.urdf_path, active, spec.ee_frame, robot.lift_joint)
    home = robot.home_configuration()
    ik.set_posture(home)
    return ik, np.array([home[j] for j in active])


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


def run(quick: bool) -> list[Figure]:
    count = 40 if quick else 300
    figures: list[Figure] = []
    for name, arm in ARMS:
        ik, home = _solver(name, arm)
        reachable = _targets(ik, home, count, seed=1)
        unreachable = []
        for T in reachable[: max(10, count // 4)]:
            far = T.copy()
            far[:3, 3] += FAR
            unreachable.append(far)
        for label, targets in (("reachable", reachable), ("unreachable", unreachable)):
            times, solved = _checks(ik, home, targets, seed=2)
            rate = solved / len(targets)
            figures.append(
                figure(
                    SECTION,
                    f"{name} {arm}: IK check, {label} target",
                    times,
                    "ms",
                    scale=1e3,
                    notes=f"success {solved}/{len(targets)} ({rate:.0%}); "
                    f"{len(times) / sum(times):.0f} checks/s",
                    extra={
                        "checks_per_s": len(times) / sum(times),
                        "success_rate": rate,
                        "n": len(targets),
                        "active_joints": list(ik.joint_names),
                    },
                )
            )
    return figures
