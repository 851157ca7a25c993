"""PickPlanner: feasibility tests and chained plans for one arm of a scene.

The planning world is set per episode with ``sync`` (a
:class:`harness.planning.world.PlanningWorld`); what it holds and the collision rules per phase
are described in ``harness.planning.collision``.

Feasibility of one candidate (``test_mode``, docs/reference-pick-skill.md section 5):

- ``ik``: IK for the pre-grasp and (when ``pre_grasp_offset > 0``) the grasp, each from the
  current joint state, within 5 mm / 0.05 rad, and each solution collision-free (the
  reference's cuRobo IK checks collisions too). No path is checked, as in the reference.
- ``forward``: the chained plan: a collision-free joint path from the current state to the
  pre-grasp (direct interpolation first, RRT-Connect within a sample budget otherwise), the
  straight Cartesian approach to the grasp, and the lift (and the return to the pre-grasp when
  asked). The plan found is the one executed. The reference plans the pre-grasp and the grasp,
  each from the current state, and never the lift: under ``semantics: reference`` the test
  leaves the carry out and it is planned (``plan_carry``) for the chosen candidate alone
  (``Semantics.test_carry``, docs/semantics.md).

Selection: ``reference`` semantics take the first feasible candidate in order, else proceed
with the last one tested; ``strict`` semantics stop with ``no_feasible_candidate``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from harness.planning.collision import CollisionChecker, Phase
from harness.planning.ik import IKResult, IKSettings, WholeBodyIK
from harness.planning.paths import PoseLine, rrt_connect, shortcut
from harness.planning.plans import CandidateVerdict, ChainPlan, FailurePoint
from harness.planning.reach import classify_reach
from harness.planning.world import PlanningWorld
from harness.sim.scene import Scene

LiftPath = Literal["joint", "cartesian"]

COLLISION_FREE_IK_ATTEMPTS = 3  # fresh IK restarts when a solution is in collision
# The reference plans every command, the lift included, with cuRobo's motion generator in joint
# space: MotionGenPlanConfig(max_attempts=10) in sequential mode (InternDataEngine
# workflows/simbox/core/controllers/template_controller.py:180-186, _init_motion_gen), goal
# thresholds cuRobo's defaults 5 mm / 0.05 (the same as its IK solver's, lines 207-210), and a
# failed plan is retried on the next step until ``num_plan_failed > 5`` ends the episode
# (template_controller.py:404-405 / 416-417, ee_forward; pick.py is_feasible(th=5)): 6 plans.
LIFT_PLAN_ATTEMPTS = 10
LIFT_PLAN_RETRIES = 6
# A joint within this distance (rad or m) of a position limit is the limiting joint of an
# unreachable target's best IK attempt.
LIMIT_MARGIN = 1e-3


@dataclass(frozen=True)
class PlannerSettings:
    """Resolutions, budgets and tolerances of the planner (SI units, joint space in rad / m)."""

    ik: IKSettings = field(default_factory=IKSettings)
    collision_resolution: float = 0.03  # max joint step between collision checks
    cartesian_step: float = 0.01  # m between Cartesian IK waypoints
    max_joint_jump: float = 0.3  # largest joint change allowed between Cartesian waypoints
    penetration_tolerance: float = 1e-4  # contacts shallower than this are not collisions
    # Budgets are counts, not seconds: a plan must not depend on machine load (same seed, same row).
    rrt_max_iterations: int = 1000  # samples per RRT-Connect query
    rrt_step: float = 0.2  # joint-space extension step
    rrt_max_nodes: int = 4000
    shortcut_iterations: int = 40
    # The joint-space lift (``lift_path: joint``): IK seeds per plan and plans per lift.
    lift_attempts: int = LIFT_PLAN_ATTEMPTS
    lift_retries: int = LIFT_PLAN_RETRIES


class PickPlanner:
    """Feasibility tests and chained plans for one arm of a scene."""

    def __init__(
        self, scene: Scene, arm: str, ik: WholeBodyIK, settings: PlannerSettings | None = None
    ) -> None:
        self.scene = scene
        self.arm = arm
        self.ik = ik
        self.settings = settings or PlannerSettings()
        self.checker = CollisionChecker(scene, arm, self.settings.penetration_tolerance)
        self.lower = ik.lower
        self.upper = ik.upper
        # The arm's shoulder: the link its second joint moves (harness.planning.reach).
        arm_joints = scene.robot.arm(arm).joints
        self.shoulder_frame = scene.robot.urdf.joints[arm_joints[1]].child
        # The configuration (and colliding pair) of the last failed check, for the verdict.
        self.last_failure: FailurePoint | None = None

    # -- helpers --------------------------------------------------------------------------------

    def _note(self, q: np.ndarray, pairs: list[tuple[int, int]] | None = None) -> str:
        """Remember ``q`` (and its first colliding pair) as the last failure; the pairs
        described as in the failure messages."""
        names = self.checker.pair_names(pairs[0]) if pairs else None
        reach = "collision" if pairs else ""
        self.last_failure = FailurePoint(np.array(q, dtype=float), names, reach_limit=reach)
        return self.checker.describe(pairs) if pairs else ""

    def _note_unreachable(self, result: IKResult, T_world_target: np.ndarray) -> str:
        """Remember the best IK attempt at an unreachable target with its residual, the joint
        at a limit there and what limits the reach (``harness.planning.reach``); returns that
        joint ('' when none is at a limit)."""
        joint = self.limiting_joint(result.q)
        free_lift = None
        if self.ik.lift_joint is not None and self.ik.lift_held:
            free_lift = lambda: self._reaches_with_free_lift(T_world_target, result.q)  # noqa: E731
        reach = classify_reach(
            self.ik, result.q, T_world_target, joint, self.shoulder_frame, free_lift
        )
        self.last_failure = FailurePoint(
            np.array(result.q, dtype=float),
            None,
            joint,
            result.position_error,
            result.orientation_error,
            reach,
        )
        return joint

    def _reaches_with_free_lift(self, T_world_target: np.ndarray, q: np.ndarray) -> bool:
        """Whether the IK reaches ``T_world_target`` from ``q`` once the held lift may move
        within its range (one deterministic solve; the lift is held again after it)."""
        self.ik.hold_lift(False)
        try:
            return self.ik.solve(T_world_target, q, None, self.settings.ik).success
        finally:
            self.ik.hold_lift(True)

    def limiting_joint(self, q: np.ndarray) -> str:
        """The active joint of ``q`` nearest a position limit, as ``name:lower`` or
        ``name:upper``, if it lies within ``LIMIT_MARGIN`` of it; else ''. (A held lift,
        whose limits are its value, is never the limiting joint.)"""
        q = np.asarray(q, dtype=float)
        best, best_gap = "", LIMIT_MARGIN
        for index, name in enumerate(self.ik.joint_names):
            lower, upper = self.lower[index], self.upper[index]
            if upper - lower <= LIMIT_MARGIN:
                continue
            for side, gap in (("lower", q[index] - lower), ("upper", upper - q[index])):
                if gap <= best_gap:
                    best, best_gap = f"{name}:{side}", float(gap)
        return best

    def sync(self, world: PlanningWorld) -> None:
        """Take the scene's current state and ``world`` as the planning world and IK posture.

        ``hold_lift`` keeps a lift joint where it is for every IK solve and joint path (the
        reference's pick plans the arm alone with the lift at its home)."""
        scene = self.scene
        self.checker.sync(world)
        self.ik.hold_lift(world.hold_lift)
        self.lower, self.upper = self.ik.lower.copy(), self.ik.upper.copy()
        if world.hold_lift and self.ik.lift_joint is not None:
            index = self.ik.joint_names.index(self.ik.lift_joint)
            value = float(scene.data.qpos[scene.arms[self.arm].active_qpos[index]])
            self.lower[index] = self.upper[index] = value
        self.ik.set_base_pose(scene.T_world_root())
        posture = {
            name: float(scene.data.qpos[adr])
            for name, adr in scene.joint_qpos.items()
            if name in scene.robot.movable_joints
        }
        self.ik.set_posture(posture)

    def collision_free_ik(
        self,
        T_world_target: np.ndarray,
        seeds: list[np.ndarray],
        phase: Phase,
        rng: np.random.Generator | None,
        attempts: int = COLLISION_FREE_IK_ATTEMPTS,
    ) -> tuple[IKResult, str]:
        """An IK solution that is also collision-free for ``phase``: from the seeds first, then
        from random restarts while the solutions collide. Returns the result and "" -- or, when
        every solution found collides, the last one and why."""
        result = self.ik.solve(T_world_target, seeds[0], rng, self.settings.ik, seeds[1:])
        colliding: tuple[IKResult, str] | None = None
        for attempt in range(attempts + 1):
            if result.success:
                pairs = self.checker.contacts(result.q, phase)
                if not pairs:
                    return result, ""
                colliding = (result, f"IK solution in collision ({self._note(result.q, pairs)})")
            elif attempt == 0:
                self._note_unreachable(result, T_world_target)  # the best attempt: unreachable
                return result, ""  # not reachable at all: restarts were already spent
            if rng is None or attempt == attempts:
                break
            restart = rng.uniform(self.lower, self.upper)  # a held lift stays where it is
            result = self.ik.solve(T_world_target, restart, rng, self.settings.ik)
        return colliding if colliding is not None else (result, "")

    def edge_free(self, phase: Phase) -> Callable[[np.ndarray, np.ndarray], bool]:
        resolution = self.settings.collision_resolution

        def free(qa: np.ndarray, qb: np.ndarray) -> bool:
            return not self.checker.segment_collides(qa, qb, phase, resolution)

        return free

    def joint_path(
        self, q_from: np.ndarray, q_to: np.ndarray, phase: Phase, rng: np.random.Generator
    ) -> tuple[np.ndarray | None, bool, str]:
        """Collision-free joint path: direct line, else RRT-Connect. (waypoints, used_rrt, why)."""
        if self.checker.collides(q_to, phase):
            pairs = self.checker.contacts(q_to, phase)
            return None, False, f"goal in collision ({self._note(q_to, pairs)})"
        if self.checker.collides(q_from, phase):
            pairs = self.checker.contacts(q_from, phase)
            return None, False, f"start in collision ({self._note(q_from, pairs)})"
        edge_free = self.edge_free(phase)
        if edge_free(q_from, q_to):
            return np.stack([q_from, q_to]), False, ""
        s = self.settings
        path = rrt_connect(
            q_from,
            q_to,
            self.lower,
            self.upper,
            lambda q: not self.checker.collides(q, phase),
            edge_free,
            rng,
            s.rrt_step,
            s.rrt_max_iterations,
            s.rrt_max_nodes,
        )
        if path is None:
            self._note(q_to)  # no single configuration failed: show the goal it did not reach
            return None, True, "RRT-Connect found no path within its budget"
        path = shortcut(path, edge_free, rng, s.shortcut_iterations)
        return np.stack(path), True, ""

    def cartesian_path(
        self, q_start: np.ndarray, T_from: np.ndarray, T_to: np.ndarray, phase: Phase
    ) -> tuple[np.ndarray | None, str]:
        """Joint waypoints following the straight line ``T_from -> T_to`` (fixed orientation
        interpolated by slerp), each an IK solution seeded by the previous one."""
        s = self.settings
        distance = float(np.linalg.norm(T_to[:3, 3] - T_from[:3, 3]))
        count = max(1, int(np.ceil(distance / s.cartesian_step)))
        waypoints = [q_start]
        q = q_start
        line = PoseLine(T_from, T_to)
        for k in range(1, count + 1):
            T = line.at(k / count)
            result = self.ik.solve(T, q, None, s.ik)
            if not result.success:
                joint = self._note_unreachable(result, T)
                return None, (
                    f"IK failed at {k}/{count} of the line ({result.position_error * 1e3:.1f} mm, "
                    f"{result.orientation_error:.3f} rad{', ' + joint if joint else ''})"
                )
            if float(np.max(np.abs(result.q - q))) > s.max_joint_jump:
                self._note(result.q)
                joint = self.ik.joint_names[int(np.argmax(np.abs(result.q - q)))]
                return None, f"joint jump at {k}/{count} of the line (IK branch change, {joint})"
            if self.checker.segment_collides(q, result.q, phase, s.collision_resolution):
                pairs = self.checker.contacts(result.q, phase)
                return None, f"collision at {k}/{count} ({self._note(result.q, pairs)})"
            waypoints.append(result.q)
            q = result.q
        return np.stack(waypoints), ""

    def joint_space_path(
        self, q_start: np.ndarray, T_to: np.ndarray, phase: Phase, rng: np.random.Generator
    ) -> tuple[np.ndarray | None, str]:
        """Joint waypoints from ``q_start`` to any configuration that puts the EE at ``T_to``
        (within the IK tolerances, 5 mm / 0.05 rad): the reference's joint-space plan to a pose
        (cuRobo ``plan_single``), whose EE path is not a straight line.

        Each of ``lift_retries`` plans tries ``lift_attempts`` IK seeds (``q_start`` first in
        the first plan, then random configurations from ``rng``); the solutions are tried
        nearest to ``q_start`` first, each with a collision-free joint path (``joint_path``:
        direct, else RRT-Connect). Returns (waypoints, "") or (None, why), with the best IK
        attempt, its residual and its limiting joint noted as the failure point."""
        s = self.settings
        best: IKResult | None = None
        path_why = ""
        for retry in range(s.lift_retries):
            solutions: list[np.ndarray] = []
            for attempt in range(s.lift_attempts):
                first = retry == 0 and attempt == 0
                seed = q_start if first else rng.uniform(self.lower, self.upper)
                result = self.ik.solve(T_to, seed, None, s.ik)
                if result.success:
                    if first:  # the grasp's own branch: take it if its path is free
                        path, _, why = self.joint_path(q_start, result.q, phase, rng)
                        if path is not None:
                            return path, ""
                        path_why = why
                    else:
                        solutions.append(result.q)
                elif best is None or result.residual < best.residual:
                    best = result
            solutions.sort(key=lambda q: float(np.sum(np.abs(q - q_start))))
            for q_goal in solutions:
                path, _, why = self.joint_path(q_start, q_goal, phase, rng)
                if path is not None:
                    return path, ""
                path_why = why
        tries = f"{s.lift_retries} plans x {s.lift_attempts} IK seeds"
        if path_why:
            return None, f"no collision-free joint path to the pose in {tries}: {path_why}"
        assert best is not None
        joint = self._note_unreachable(best, T_to)
        return None, (
            f"pose out of reach in {tries}: best IK residual {best.position_error * 1e3:.1f} mm"
            f" / {best.orientation_error:.3f} rad{' at ' + joint if joint else ''}"
        )

    # -- feasibility ----------------------------------------------------------------------------

    def test_ik(
        self,
        position: int,
        pose_index: int,
        score: float,
        q_current: np.ndarray,
        T_world_pregrasp: np.ndarray,
        T_world_grasp: np.ndarray,
        test_grasp: bool,
        rng: np.random.Generator,
    ) -> CandidateVerdict:
        """``ik`` mode: the pre-grasp and the grasp, each from the current state, each solution
        checked for collisions (as the reference's collision-aware IK does; the grasp with the
        approach rules, so the fingers may touch the object)."""
        start = time.perf_counter()
        self.last_failure = None
        pre, why = self.collision_free_ik(T_world_pregrasp, [q_current], "transport", rng)
        verdict = CandidateVerdict(position, pose_index, score, False, "", ik_pregrasp=pre)
        if not pre.success or why:
            verdict.stage = "ik_pregrasp"
            verdict.detail = why or _ik_detail(pre)
        elif test_grasp:
            grasp, why = self.collision_free_ik(T_world_grasp, [q_current], "approach", rng)
            verdict.ik_grasp = grasp
            if not grasp.success or why:
                verdict.stage = "ik_grasp"
                verdict.detail = why or _ik_detail(grasp)
        verdict.feasible = verdict.stage == ""
        if not verdict.feasible:
            verdict.failure_point = self.last_failure
        verdict.time_s = time.perf_counter() - start
        return verdict

    def plan_chain(
        self,
        position: int,
        pose_index: int,
        score: float,
        q_current: np.ndarray,
        T_world_pregrasp: np.ndarray,
        T_world_grasp: np.ndarray,
        T_world_lift: np.ndarray | None,
        return_to_pregrasp: bool,
        rng: np.random.Generator,
        pregrasp_seed: np.ndarray | None = None,
        lift_path: LiftPath = "cartesian",
    ) -> CandidateVerdict:
        """``forward`` mode (and execution planning): the whole chained, checked motion.

        ``pregrasp_seed`` (e.g. the solution an ``ik`` test found) is tried before the current
        state as the pre-grasp IK seed; ``lift_path`` is how the lift is planned
        (``plan_carry``)."""
        start = time.perf_counter()
        verdict = CandidateVerdict(position, pose_index, score, False, "")

        self.last_failure = None

        def fail(stage: str, detail: str) -> CandidateVerdict:
            verdict.stage, verdict.detail = stage, detail
            verdict.failure_point = self.last_failure
            verdict.time_s = time.perf_counter() - start
            return verdict

        seeds = [q_current] if pregrasp_seed is None else [pregrasp_seed, q_current]
        pre, why = self.collision_free_ik(T_world_pregrasp, seeds, "transport", rng)
        verdict.ik_pregrasp = pre
        if not pre.success:
            return fail("ik_pregrasp", _ik_detail(pre))
        if why:
            return fail("ik_pregrasp", why)
        transport, used_rrt, why = self.joint_path(q_current, pre.q, "transport", rng)
        if transport is None:
            return fail("transport", why)
        # The approach starts from the exact pre-grasp pose the transport ends at.
        T_pre_exact = self.ik.fk(pre.q)
        approach, why = self.cartesian_path(pre.q, T_pre_exact, T_world_grasp, "approach")
        if approach is None:
            return fail("approach", why)
        verdict.ik_grasp = IKResult(approach[-1], True, 0.0, 0.0, 0, 0)
        plan = ChainPlan(
            transport=transport,
            approach=approach,
            lift=None,
            retreat=None,
            T_world_pregrasp=T_world_pregrasp,
            T_world_grasp=T_world_grasp,
            T_world_lift=None,
            used_rrt=used_rrt,
        )
        carried, stage, why = self.plan_carry(
            plan, T_world_lift, return_to_pregrasp, lift_path, rng
        )
        if carried is None:
            return fail(stage, why)
        verdict.plan = carried
        verdict.feasible = True
        verdict.time_s = time.perf_counter() - start
        return verdict

    def plan_carry(
        self,
        plan: ChainPlan,
        T_world_lift: np.ndarray | None,
        return_to_pregrasp: bool,
        lift_path: LiftPath = "cartesian",
        rng: np.random.Generator | None = None,
    ) -> tuple[ChainPlan | None, str, str]:
        """Extend a plan that ends at the grasp with the carry: the lift to ``T_world_lift``
        (if any) and, with ``return_to_pregrasp``, the line back to the pre-grasp the transport
        reached. Returns (the extended plan, "", "") or (None, stage, why) with stage ``lift``
        or ``return``.

        ``lift_path``: ``joint`` plans the lift as the reference does, in joint space to the
        lift pose (``joint_space_path``; random IK seeds from ``rng``, a fixed stream when
        None); ``cartesian`` follows the straight line (deterministic)."""
        self.checker.attach(plan.approach[-1])  # the target in the hand (when the world says)
        try:
            return self._carry(plan, T_world_lift, return_to_pregrasp, lift_path, rng)
        finally:
            self.checker.detach()

    def _carry(
        self,
        plan: ChainPlan,
        T_world_lift: np.ndarray | None,
        return_to_pregrasp: bool,
        lift_path: LiftPath,
        rng: np.random.Generator | None,
    ) -> tuple[ChainPlan | None, str, str]:
        lift = None
        retreat = None
        q_end = plan.approach[-1]
        if T_world_lift is not None:
            if lift_path == "joint":
                stream = rng if rng is not None else np.random.default_rng(0)
                lift, why = self.joint_space_path(q_end, T_world_lift, "carry", stream)
            else:
                T_grasp_exact = self.ik.fk(q_end)
                lift, why = self.cartesian_path(q_end, T_grasp_exact, T_world_lift, "carry")
            if lift is None:
                return None, "lift", why
            q_end = lift[-1]
        if return_to_pregrasp:
            T_pre_exact = self.ik.fk(plan.approach[0])
            retreat, why = self.cartesian_path(q_end, self.ik.fk(q_end), T_pre_exact, "carry")
            if retreat is None:
                return None, "return", why
        return (
            ChainPlan(
                transport=plan.transport,
                approach=plan.approach,
                lift=lift,
                retreat=retreat,
                T_world_pregrasp=plan.T_world_pregrasp,
                T_world_grasp=plan.T_world_grasp,
                T_world_lift=T_world_lift,
                used_rrt=plan.used_rrt,
            ),
            "",
            "",
        )


def _ik_detail(result: IKResult) -> str:
    return (
        f"IK residual {result.position_error * 1e3:.1f} mm / {result.orientation_error:.3f} rad "
        f"after {result.iterations} iterations, {result.restarts} restarts"
    )
