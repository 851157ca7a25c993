"""Whole-body inverse kinematics with placo, for one arm of a robot (plus the lift, if any).

placo always adds a floating base; here it is masked (pinned) and placed with
``set_base_pose(T_world_fbase)`` at the robot root's world pose in MuJoCo, so placo and MuJoCo
agree on every frame. The *active* joints are the picking arm's joints, preceded by the lift
joint on a robot that has one (Lift-2): they are solved together. Everything else (the idle
arm, the fingers) is masked and holds the posture last given with ``set_posture``.

The solve is Gauss-Newton through placo's QP (joint limits are hard constraints), with:

- a frame task on the end-effector frame (soft, position and orientation weight 1);
- on a lift, a weak posture task that keeps the lift where it is unless the arm alone cannot
  reach; it is dropped for the final polish so it never leaves a residual
  (../shared/reference/libraries.md section 1, "soft weights compete"); ``hold_lift(True)``
  masks the lift instead, so it stays at its seed value (the reference's pick holds the lift at
  its home and plans the arm alone, which is what the episode does);
- convergence tolerances, an iteration cap, a stall test, and random restarts drawn from a
  ``numpy.random.Generator``. The solve always returns within ``max_iterations * (1 +
  max_restarts)`` iterations, with the best solution found and its residual.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import placo

from harness.errors import InputFileError

LOOSE_EXTRA_ATTEMPTS = 4  # restarts tried after a success that did not converge tightly


@dataclass(frozen=True)
class IKSettings:
    """Tolerances and effort caps of one IK query.

    ``position_tolerance`` / ``orientation_tolerance`` decide success (the reference's cuRobo
    thresholds: 5 mm, 0.05 rad); the solver keeps iterating down to the much tighter
    ``converge_*`` values so an accepted solution is also an accurate one.
    """

    position_tolerance: float = 0.005
    orientation_tolerance: float = 0.05
    converge_position: float = 1e-5
    converge_orientation: float = 1e-4
    max_iterations: int = 60
    max_restarts: int = 6
    stall_step: float = 1e-7
    stall_window: int = 8
    stall_improvement: float = 0.02


@dataclass(frozen=True)
class IKResult:
    """The best joint solution found for one target, with its residual."""

    q: np.ndarray  # active joint values, in WholeBodyIK.joint_names order
    success: bool
    position_error: float  # m
    orientation_error: float  # rad
    iterations: int
    restarts: int

    @property
    def residual(self) -> float:
        """A single number for ranking: position error plus 0.1 m per radian."""
        return self.position_error + 0.1 * self.orientation_error


def pose_errors(T_current: np.ndarray, T_target: np.ndarray) -> tuple[float, float]:
    """Position (m) and orientation (rad, geodesic angle) error between two 4x4 poses."""
    position = float(np.linalg.norm(T_current[:3, 3] - T_target[:3, 3]))
    R = T_current[:3, :3].T @ T_target[:3, :3]
    cos_angle = np.clip(0.5 * (np.trace(R) - 1.0), -1.0, 1.0)
    return position, float(np.arccos(cos_angle))


class WholeBodyIK:
    """placo IK for ``ee_frame`` over ``active_joints`` (lift first, then the arm joints).

    ``limits`` optionally overrides the URDF position limits per joint name (lower, upper).
    """

    def __init__(
        self,
        urdf_path: str | Path,
        active_joints: Sequence[str],
        ee_frame: str,
        lift_joint: str | None = None,
        limits: Mapping[str, tuple[float, float]] | None = None,
        lift_posture_weight: float = 1e-2,
    ) -> None:
        path = Path(urdf_path)
        if not path.is_file():
            raise InputFileError(path, "URDF file not found")
        try:
            self.robot = placo.RobotWrapper(str(path), placo.Flags.ignore_collisions)
        except (RuntimeError, ValueError) as exc:
            raise InputFileError(path, f"placo cannot load the URDF: {exc}") from None
        known = set(self.robot.joint_names())
        missing = [j for j in active_joints if j not in known]
        if missing or ee_frame not in set(self.robot.frame_names()):
            raise InputFileError(
                path, f"unknown joints {missing} or frame {ee_frame!r} for IK", key="joints"
            )
        self.urdf_path = path
        self.joint_names: tuple[str, ...] = tuple(active_joints)
        self.ee_frame = ee_frame
        self.lift_joint = lift_joint
        self._offsets = np.array([self.robot.get_joint_offset(j) for j in self.joint_names])
        if limits:
            for name, (lower, upper) in limits.items():
                if name in known:
                    self.robot.set_joint_limits(name, float(lower), float(upper))
        bounds = np.array([self.robot.get_joint_limits(j) for j in self.joint_names], dtype=float)
        self.lower = bounds[:, 0].copy()
        self.upper = bounds[:, 1].copy()

        self.solver = placo.KinematicsSolver(self.robot)
        self.solver.mask_fbase(True)
        for name in known - set(self.joint_names):
            self.solver.mask_dof(name)
        self.task = self.solver.add_frame_task(ee_frame, np.eye(4))
        self.task.configure(ee_frame, "soft", 1.0, 1.0)
        self.solver.add_regularization_task(1e-6)
        self._lift_task = None
        self._lift_weight = float(lift_posture_weight)
        self._lift_held = False
        if lift_joint is not None:
            if lift_joint not in self.joint_names:
                raise ValueError(f"lift joint {lift_joint!r} must be one of the active joints")
            self._lift_task = self.solver.add_joints_task()
            self._lift_task.configure("lift_posture", "soft", self._lift_weight)
        self.robot.update_kinematics()
        self.total_time = 0.0  # seconds spent in solve(), for the episode's ik_time_s

    # -- state ----------------------------------------------------------------------------------

    @property
    def lift_held(self) -> bool:
        return self._lift_held

    def hold_lift(self, held: bool) -> None:
        """Keep the lift at its seed value in every solve (masked), or solve it with the arm."""
        if self.lift_joint is None or held == self._lift_held:
            return
        if held:
            self.solver.mask_dof(self.lift_joint)
        else:
            self.solver.unmask_dof(self.lift_joint)
        self._lift_held = held

    def set_base_pose(self, T_world_fbase: np.ndarray) -> None:
        """Place the (pinned) floating base: the robot root's world pose in the scene."""
        self.robot.set_T_world_fbase(np.asarray(T_world_fbase, dtype=float))
        self.robot.update_kinematics()

    def set_posture(self, values: Mapping[str, float]) -> None:
        """Set any joints by name (idle arm, fingers, and the active joints' defaults)."""
        q = self.robot.state.q
        for name, value in values.items():
            # Clipped to the limits: placo's QP is infeasible if any joint (even a masked one,
            # e.g. a finger a hair past its stop in simulation) starts outside them.
            lower, upper = self.robot.get_joint_limits(name)
            q[self.robot.get_joint_offset(name)] = min(max(float(value), lower), upper)
        self.robot.state.q = q
        self.robot.update_kinematics()

    def _set_active(self, q_active: np.ndarray) -> None:
        q = self.robot.state.q
        q[self._offsets] = q_active
        self.robot.state.q = q
        self.robot.state.qd = np.zeros_like(self.robot.state.qd)
        self.robot.update_kinematics()

    def _get_active(self) -> np.ndarray:
        return self.robot.state.q[self._offsets].copy()

    def fk(self, q_active: np.ndarray, frame: str | None = None) -> np.ndarray:
        """World pose of ``frame`` (default the EE frame) at active joints ``q_active``."""
        self._set_active(np.asarray(q_active, dtype=float))
        return np.array(self.robot.get_T_world_frame(frame or self.ee_frame))

    def clip(self, q_active: np.ndarray) -> np.ndarray:
        return np.clip(q_active, self.lower, self.upper)

    def random_configuration(self, rng: np.random.Generator) -> np.ndarray:
        return rng.uniform(self.lower, self.upper)

    # -- solving --------------------------------------------------------------------------------

    def _iterate(self, settings: IKSettings, polish: bool) -> tuple[int, bool]:
        """Gauss-Newton steps until converged, stalled or capped; returns (iterations, ok)."""
        pos_task = self.task.position()
        rot_task = self.task.orientation()
        history: list[float] = []
        for iteration in range(1, settings.max_iterations + 1):
            try:
                dq = self.solver.solve(True)
            except RuntimeError:  # infeasible QP (e.g. a seed outside the limits)
                return iteration, False
            self.robot.update_kinematics()
            # placo reports the error before the step it just took: a conservative test.
            err_p = pos_task.error_norm()
            err_r = rot_task.error_norm()
            if err_p < settings.converge_position and err_r < settings.converge_orientation:
                return iteration, True
            step = float(np.max(np.abs(dq))) if len(dq) else 0.0
            if step < settings.stall_step:
                return iteration, True
            history.append(err_p + 0.1 * err_r)
            window = settings.stall_window
            if len(history) > window and not polish:
                old = history[-window - 1]
                if history[-1] > old * (1.0 - settings.stall_improvement):
                    return iteration, True
        return settings.max_iterations, True

    def _solve_from(
        self, T_target: np.ndarray, seed: np.ndarray, settings: IKSettings
    ) -> tuple[np.ndarray, float, float, int]:
        self._set_active(self.clip(seed))
        iterations = 0
        free_lift = False
        if self._lift_task is not None and not self._lift_held:
            free_lift = True
            lift_index = self.joint_names.index(self.lift_joint)  # type: ignore[arg-type]
            self._lift_task.set_joints({self.lift_joint: float(seed[lift_index])})
            self._lift_task.configure("lift_posture", "soft", self._lift_weight)
            used, _ = self._iterate(settings, polish=False)
            iterations += used
            self._lift_task.configure("lift_posture", "soft", 0.0)
        used, _ = self._iterate(settings, polish=free_lift)
        iterations += used
        T_now = np.array(self.robot.get_T_world_frame(self.ee_frame))
        err_p, err_r = pose_errors(T_now, T_target)
        return self._get_active(), err_p, err_r, iterations

    def solve(
        self,
        T_world_target: np.ndarray,
        seed: np.ndarray,
        rng: np.random.Generator | None = None,
        settings: IKSettings | None = None,
        extra_seeds: Sequence[np.ndarray] = (),
    ) -> IKResult:
        """Joint values putting the EE frame at ``T_world_target``.

        Tries ``seed``, then each of ``extra_seeds``, then up to ``max_restarts`` random
        configurations from ``rng`` (none without one). It stops at the first tightly converged
        solution; a solution that is only within the acceptance tolerances gets a few more
        restarts to find a tighter one. The best solution (success first, then residual) wins.
        """
        started = time.perf_counter()
        settings = settings or IKSettings()
        T_target = np.asarray(T_world_target, dtype=float)
        self.task.T_world_frame = T_target
        seeds = [np.asarray(seed, dtype=float), *(np.asarray(s, dtype=float) for s in extra_seeds)]
        best: IKResult | None = None
        total = 0
        loose_tries = 0
        attempts = len(seeds) + (settings.max_restarts if rng is not None else 0)
        for attempt in range(attempts):
            if attempt < len(seeds):
                start = seeds[attempt]
            else:
                start = self.random_configuration(rng)  # type: ignore[arg-type]
                if self.lift_joint is not None:  # restart the arm, keep the lift's seed
                    lift_index = self.joint_names.index(self.lift_joint)
                    start[lift_index] = seeds[0][lift_index]
            q, err_p, err_r, used = self._solve_from(T_target, start, settings)
            total += used
            ok = err_p <= settings.position_tolerance and err_r <= settings.orientation_tolerance
            candidate = IKResult(q, ok, err_p, err_r, total, attempt)
            if (
                best is None
                or (ok and not best.success)
                or (ok == best.success and candidate.residual < best.residual)
            ):
                best = candidate
            tight = (
                err_p <= 10 * settings.converge_position
                and err_r <= 10 * settings.converge_orientation
            )
            if tight:
                break
            if best.success:  # accepted but not converged tightly: a few more tries
                loose_tries += 1
                if loose_tries > LOOSE_EXTRA_ATTEMPTS:
                    break
        assert best is not None
        self.total_time += time.perf_counter() - started
        return IKResult(
            best.q, best.success, best.position_error, best.orientation_error, total, best.restarts
        )
