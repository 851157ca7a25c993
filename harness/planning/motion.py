"""Motion planning for a pick: collision checks, joint paths, Cartesian paths, feasibility.

Collision checks run on the scene's ``check_model`` (robot-table contact always on) with a
private ``MjData``: set the active joints, ``mj_kinematics`` + ``mj_collision``, classify the
contacts. What counts as a collision depends on the phase of the motion:

- ``transport`` (current state -> pre-grasp): any robot part except the parts welded to the root
  against the table or any object; any robot-robot contact the physics model has (MuJoCo leaves
  out parent-child and welded pairs and the excluded finger pair), within an arm or across the
  two arms -- planning sees exactly the self-contacts that would stop the arm in simulation;
- ``approach`` (pre-grasp -> grasp): the same, except the picking arm's fingers may touch the
  target object (a palm pressing on it would stop the hand short of the grasp);
- ``carry`` (lift and return, the object in the hand): the same, except nothing of the robot
  is checked against the target object.

What the planning world holds is set per episode (``sync``): the table (the episode puts it in
only where the robot physically collides with it, or under strict semantics: the reference's
planning always ignores it, quirk 21) and the target object (the episode always puts it in; the
reference removes it while planning the pre-grasp and the grasp,
docs/reference-pick-skill.md section 6).

Feasibility of one candidate (``test_mode``, docs/reference-pick-skill.md section 5):

- ``ik``: IK for the pre-grasp and (when ``pre_grasp_offset > 0``) the grasp, each from the
  current joint state, within 5 mm / 0.05 rad, and each solution collision-free (the
  reference's cuRobo IK checks collisions too). No path is checked, as in the reference.
- ``forward``: the chained plan: a collision-free joint path from the current state to the
  pre-grasp (direct interpolation first, RRT-Connect within a sample budget otherwise), the
  straight Cartesian approach to the grasp, and the lift (and the return to the pre-grasp when
  asked). The plan found is the one executed. The reference plans the pre-grasp and the grasp,
  each from the current state, and never the lift; the episode can test without the carry and
  plan it (``plan_carry``) for the chosen candidate alone
  (``harness.episode.FORWARD_TEST_PLANS_CARRY``, docs/semantics.md).

Selection: ``reference`` semantics take the first feasible candidate in order, else proceed
with the last one tested; ``strict`` semantics stop with ``no_feasible_candidate``.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Literal

import mujoco
import numpy as np

from harness.planning.ik import IKResult, IKSettings, WholeBodyIK
from harness.sim.scene import TABLE_BIT, Scene, refresh_body_masks

Phase = Literal["transport", "approach", "carry"]
COLLISION_FREE_IK_ATTEMPTS = 3  # fresh IK restarts when a solution is in collision
Collides = Callable[[np.ndarray], bool]


# --------------------------------------------------------------------------------------------
# Settings


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


# --------------------------------------------------------------------------------------------
# Collision checking


class CollisionChecker:
    """Collision queries for one arm's active joints on the scene's check model."""

    def __init__(self, scene: Scene, arm: str, penetration_tolerance: float = 1e-4) -> None:
        self.scene = scene
        self.tolerance = penetration_tolerance
        self.model = scene.check_model
        self.data = mujoco.MjData(self.model)
        self.handles = scene.arms[arm]
        m = self.model
        self.robot = scene.robot_geom.copy()
        self.moving = scene.robot_geom & ~scene.static_robot_geom
        self.finger = self.handles.finger_geom_side >= 0
        self.geom_object = scene.geom_object
        self.geom_body = m.geom_bodyid.copy()
        self.target_index = -1
        self.check_table = True
        self.check_target = True
        self.table_clearance = 0.0
        self.ignored_geom = np.zeros(m.ngeom, dtype=bool)  # geoms of ignored objects
        self.allowed: set[tuple[int, int]] = set()
        self.checks = 0

    def sync(
        self,
        target_object: str,
        check_table: bool = True,
        check_target: bool = True,
        table_clearance: float = 0.0,
        ignore_substring: Sequence[str] = (),
    ) -> None:
        """Copy the scene's current state (robot root, all joints, objects) into the checker.

        ``table_clearance`` (m) makes coming closer than that to the table a collision.
        ``ignore_substring`` leaves every other object whose name contains one of the
        substrings out of the planning world (the pick's ``ignore_substring``, the reference
        planner's ignore list); the target object follows ``check_target`` alone.

        ``check_table`` False leaves the table out of the planning world (the reference's
        planning ignore list always holds it); ``check_target`` False leaves the target object
        out (the reference removes it before testing and planning the pre-grasp and the grasp,
        docs/reference-pick-skill.md section 6 step 2).
        Contacts present in the current state (a first
        link standing in the table top, two links of a noisy home posture touching) are where
        the robot already is, not planning failures: those pairs are allowed for the queries
        that follow.
        """
        table = self.scene.table_geom
        bits = TABLE_BIT if check_table else 0
        self.model.geom_contype[table] = bits
        self.model.geom_conaffinity[table] = bits
        self.model.geom_margin[table] = table_clearance
        self.table_clearance = table_clearance
        refresh_body_masks(self.model)
        self.check_table = check_table
        self.check_target = check_target
        src, dst = self.scene.data, self.data
        dst.qpos[:] = src.qpos
        dst.mocap_pos[:] = src.mocap_pos
        dst.mocap_quat[:] = src.mocap_quat
        self.target_index = self.scene.object_names.index(target_object)
        ignored = [
            index
            for index, name in enumerate(self.scene.object_names)
            if index != self.target_index and any(part in name for part in ignore_substring)
        ]
        self.ignored_geom = np.isin(self.geom_object, ignored) & (self.geom_object >= 0)
        self.allowed = set()
        q_now = src.qpos[self.handles.active_qpos].copy()
        self.allowed = set(self.contacts(q_now, "transport"))

    def contacts(
        self, q_active: np.ndarray, phase: Phase, tolerance: float | None = None
    ) -> list[tuple[int, int]]:
        """Offending (geom, geom) pairs at ``q_active`` for ``phase``: penetrating deeper than
        ``tolerance`` (default: the checker's planning tolerance)."""
        m, d = self.model, self.data
        d.qpos[self.handles.active_qpos] = q_active
        mujoco.mj_kinematics(m, d)
        mujoco.mj_collision(m, d)
        self.checks += 1
        ncon = d.ncon
        if ncon == 0:
            return []
        geoms = d.contact.geom[:ncon]
        g1, g2 = geoms[:, 0], geoms[:, 1]
        limit = -(self.tolerance if tolerance is None else tolerance)
        dist = d.contact.dist[:ncon]
        if self.table_clearance > 0.0:
            table = self.scene.table_geom
            deep = dist < np.where((g1 == table) | (g2 == table), self.table_clearance, limit)
        else:
            deep = dist < limit
        robot, moving = self.robot, self.moving
        obj = self.geom_object
        env_hit = (moving[g1] & ~robot[g2]) | (moving[g2] & ~robot[g1])
        if phase == "approach" and self.check_target:
            fingers_on_target = (self.finger[g1] & (obj[g2] == self.target_index)) | (
                self.finger[g2] & (obj[g1] == self.target_index)
            )
            env_hit &= ~fingers_on_target
        if phase == "carry" or not self.check_target:
            on_target = (robot[g1] & (obj[g2] == self.target_index)) | (
                robot[g2] & (obj[g1] == self.target_index)
            )
            env_hit &= ~on_target
        env_hit &= ~(self.ignored_geom[g1] | self.ignored_geom[g2])
        robot_pair = robot[g1] & robot[g2]
        hits = deep & (env_hit | robot_pair)
        out = []
        for i in np.flatnonzero(hits):
            a, b = int(g1[i]), int(g2[i])
            if (a, b) in self.allowed:
                continue
            out.append((a, b))
        return out

    def collides(self, q_active: np.ndarray, phase: Phase) -> bool:
        return bool(self.contacts(q_active, phase))

    def segment_collides(
        self, qa: np.ndarray, qb: np.ndarray, phase: Phase, resolution: float
    ) -> bool:
        """Check the straight joint-space segment ``qa -> qb`` (both ends included)."""
        span = float(np.max(np.abs(qb - qa))) if len(qa) else 0.0
        count = max(1, int(np.ceil(span / resolution)))
        # Coarse-to-fine order finds a collision in the middle of a long segment early.
        order = _van_der_corput_order(count + 1)
        return any(self.collides(qa + (qb - qa) * (k / count), phase) for k in order)

    def describe(self, pairs: list[tuple[int, int]]) -> str:
        m = self.model
        return ", ".join(
            f"{m.body(int(m.geom_bodyid[a])).name}/{m.body(int(m.geom_bodyid[b])).name}"
            for a, b in pairs
        )


def _van_der_corput_order(n: int) -> list[int]:
    """0..n-1 with the ends first, then midpoints of ever finer halvings."""
    if n <= 2:
        return list(range(n))
    order = [0, n - 1]
    seen = set(order)
    step = n - 1
    while step > 1:
        half = step // 2 if step // 2 else 1
        for start in range(0, n - 1, step):
            k = start + half
            if k < n and k not in seen:
                seen.add(k)
                order.append(k)
        step = half
    order.extend(k for k in range(n) if k not in seen)
    return order


# --------------------------------------------------------------------------------------------
# RRT-Connect in joint space


def rrt_connect(
    start: np.ndarray,
    goal: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    config_free: Callable[[np.ndarray], bool],
    edge_free: Callable[[np.ndarray, np.ndarray], bool],
    rng: np.random.Generator,
    step: float,
    max_iterations: int,
    max_nodes: int,
) -> list[np.ndarray] | None:
    """Bidirectional RRT (RRT-Connect) from ``start`` to ``goal``; None when the budget runs out.

    The budget is ``max_iterations`` samples and ``max_nodes`` tree nodes, never wall time, so
    the result depends only on the inputs and ``rng``.

    ``config_free(q)`` and ``edge_free(qa, qb)`` are the collision tests. Trees grow by at most
    ``step`` (max-norm) per extension; the other tree greedily connects towards each new node.
    """
    trees: list[tuple[list[np.ndarray], list[int]]] = [([start], [-1]), ([goal], [-1])]

    def nearest(nodes: list[np.ndarray], q: np.ndarray) -> int:
        return int(np.argmin(np.max(np.abs(np.asarray(nodes) - q), axis=1)))

    def extend(tree: tuple[list[np.ndarray], list[int]], q: np.ndarray) -> tuple[str, int]:
        nodes, parents = tree
        i = nearest(nodes, q)
        delta = q - nodes[i]
        dist = float(np.max(np.abs(delta)))
        new = q if dist <= step else nodes[i] + delta * (step / dist)
        if not config_free(new) or not edge_free(nodes[i], new):
            return "trapped", -1
        nodes.append(new)
        parents.append(i)
        return ("reached" if dist <= step else "advanced"), len(nodes) - 1

    def path_to_root(tree: tuple[list[np.ndarray], list[int]], index: int) -> list[np.ndarray]:
        nodes, parents = tree
        out = []
        while index >= 0:
            out.append(nodes[index])
            index = parents[index]
        return out

    a, b = 0, 1
    for _ in range(max_iterations):
        if len(trees[0][0]) + len(trees[1][0]) >= max_nodes:
            break
        sample = lower + (upper - lower) * rng.random(len(lower))
        status, new_index = extend(trees[a], sample)
        if status != "trapped":
            target = trees[a][0][new_index]
            while True:
                status_b, index_b = extend(trees[b], target)
                if status_b != "advanced":
                    break
            if status_b == "reached":
                half_a = path_to_root(trees[a], new_index)[::-1]
                half_b = path_to_root(trees[b], index_b)
                path = half_a + half_b[1:]
                return path if a == 0 else path[::-1]
        a, b = b, a
    return None


def shortcut(
    path: list[np.ndarray],
    edge_free: Callable[[np.ndarray, np.ndarray], bool],
    rng: np.random.Generator,
    iterations: int,
) -> list[np.ndarray]:
    """Random shortcutting: replace sub-paths by straight segments when they are free."""
    path = list(path)
    for _ in range(iterations):
        if len(path) <= 2:
            break
        i, j = sorted(rng.choice(len(path), size=2, replace=False))
        if j - i < 2:
            continue
        if edge_free(path[i], path[j]):
            path = path[: i + 1] + path[j:]
    return path


# --------------------------------------------------------------------------------------------
# Plans and verdicts


@dataclass
class ChainPlan:
    """Joint waypoints (active joints) of one candidate's executed motion, and its targets."""

    transport: np.ndarray  # (K, n) current -> pre-grasp
    approach: np.ndarray  # (K, n) pre-grasp -> grasp (Cartesian straight line)
    lift: np.ndarray | None  # (K, n) grasp -> lifted (Cartesian), None without a lift
    retreat: np.ndarray | None  # (K, n) lifted -> pre-grasp, with return_to_pregrasp
    T_world_pregrasp: np.ndarray
    T_world_grasp: np.ndarray
    T_world_lift: np.ndarray | None
    used_rrt: bool = False


@dataclass
class CandidateVerdict:
    """Outcome of testing one candidate (one entry of the ordered candidate list)."""

    position: int  # position in the candidate list
    pose_index: int  # index into the 2N EE poses
    score: float
    feasible: bool
    stage: str  # "" when feasible, else where it failed (ik_pregrasp, transport, ...)
    detail: str = ""
    ik_pregrasp: IKResult | None = None
    ik_grasp: IKResult | None = None
    plan: ChainPlan | None = None
    time_s: float = 0.0


@dataclass
class Selection:
    """The candidate chosen for execution and how the choice was made."""

    chosen: CandidateVerdict | None
    verdicts: list[CandidateVerdict]
    outcome: Literal["feasible", "fallback_last", "none"]
    ik_time_s: float
    plan_time_s: float

    @property
    def n_feasible(self) -> int:
        return sum(v.feasible for v in self.verdicts)


# --------------------------------------------------------------------------------------------
# Planner


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

    # -- helpers --------------------------------------------------------------------------------

    def sync(
        self,
        target_object: str,
        check_table: bool = True,
        check_target: bool = True,
        table_clearance: float = 0.0,
        ignore_substring: Sequence[str] = (),
        hold_lift: bool = False,
    ) -> None:
        """Take the scene's current state as the planning world and IK posture.

        ``hold_lift`` keeps a lift joint where it is for every IK solve and joint path (the
        reference's pick plans the arm alone with the lift at its home)."""
        scene = self.scene
        self.checker.sync(
            target_object, check_table, check_target, table_clearance, ignore_substring
        )
        self.ik.hold_lift(hold_lift)
        self.lower, self.upper = self.ik.lower.copy(), self.ik.upper.copy()
        if hold_lift and self.ik.lift_joint is not None:
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
                colliding = (result, f"IK solution in collision ({self.checker.describe(pairs)})")
            elif attempt == 0:
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
            return None, False, f"goal in collision ({self.checker.describe(pairs)})"
        if self.checker.collides(q_from, phase):
            pairs = self.checker.contacts(q_from, phase)
            return None, False, f"start in collision ({self.checker.describe(pairs)})"
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
        for k in range(1, count + 1):
            T = interpolate_pose(T_from, T_to, k / count)
            result = self.ik.solve(T, q, None, s.ik)
            if not result.success:
                return None, (
                    f"IK failed at {k}/{count} of the line ({result.position_error * 1e3:.1f} mm, "
                    f"{result.orientation_error:.3f} rad)"
                )
            if float(np.max(np.abs(result.q - q))) > s.max_joint_jump:
                return None, f"joint jump at {k}/{count} of the line (IK branch change)"
            if self.checker.segment_collides(q, result.q, phase, s.collision_resolution):
                pairs = self.checker.contacts(result.q, phase)
                return None, f"collision at {k}/{count} ({self.checker.describe(pairs)})"
            waypoints.append(result.q)
            q = result.q
        return np.stack(waypoints), ""

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
    ) -> CandidateVerdict:
        """``forward`` mode (and execution planning): the whole chained, checked motion.

        ``pregrasp_seed`` (e.g. the solution an ``ik`` test found) is tried before the current
        state as the pre-grasp IK seed."""
        start = time.perf_counter()
        verdict = CandidateVerdict(position, pose_index, score, False, "")

        def fail(stage: str, detail: str) -> CandidateVerdict:
            verdict.stage, verdict.detail = stage, detail
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
        carried, stage, why = self.plan_carry(plan, T_world_lift, return_to_pregrasp)
        if carried is None:
            return fail(stage, why)
        verdict.plan = carried
        verdict.feasible = True
        verdict.time_s = time.perf_counter() - start
        return verdict

    def plan_carry(
        self, plan: ChainPlan, T_world_lift: np.ndarray | None, return_to_pregrasp: bool
    ) -> tuple[ChainPlan | None, str, str]:
        """Extend a plan that ends at the grasp with the carry: the Cartesian lift to
        ``T_world_lift`` (if any) and, with ``return_to_pregrasp``, the line back to the
        pre-grasp the transport reached. Returns (the extended plan, "", "") or (None, stage,
        why) with stage ``lift`` or ``return``. Deterministic (no random restarts)."""
        lift = None
        retreat = None
        q_end = plan.approach[-1]
        if T_world_lift is not None:
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


def interpolate_pose(T_a: np.ndarray, T_b: np.ndarray, s: float) -> np.ndarray:
    """Linear position and slerp orientation between two poses, ``s`` in [0, 1]."""
    out = np.eye(4)
    out[:3, 3] = T_a[:3, 3] + (T_b[:3, 3] - T_a[:3, 3]) * s
    R_rel = T_a[:3, :3].T @ T_b[:3, :3]
    angle = float(np.arccos(np.clip(0.5 * (np.trace(R_rel) - 1.0), -1.0, 1.0)))
    if angle < 1e-9:
        out[:3, :3] = T_a[:3, :3] if s < 0.5 else T_b[:3, :3]
        return out
    axis = np.array(
        [R_rel[2, 1] - R_rel[1, 2], R_rel[0, 2] - R_rel[2, 0], R_rel[1, 0] - R_rel[0, 1]]
    )
    norm = np.linalg.norm(axis)
    if norm < 1e-12:  # angle ~ pi: pick the axis from the symmetric part
        w, v = np.linalg.eigh(R_rel)
        axis = v[:, int(np.argmax(w))]
    else:
        axis = axis / norm
    out[:3, :3] = T_a[:3, :3] @ _axis_angle(axis, angle * s)
    return out


def _axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    x, y, z = axis
    K = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * (K @ K)
