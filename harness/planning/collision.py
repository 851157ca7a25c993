"""Collision checks of one arm's motion on the scene's planning model.

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
  is checked against the target object; where the world attaches it (``attach``, the
  reference's ``attach_obj``), the target rides in the hand and is checked against the rest of
  the world.

What the planning world holds is set per episode (``sync``, a ``PlanningWorld`` that
``harness.pick.semantics.Semantics.planning_world`` decides): the table (out under reference
semantics, as the reference's default ignore list leaves it out, quirk 21; in under strict),
the target object (out under reference for the transport and the approach, as its pick removes
it with ``update_specific``; attached to the hand for the carry: ``attach``), and the robot
(under reference only the planned arm counts, against the environment and itself).
"""

from __future__ import annotations

from typing import Literal

import mujoco
import numpy as np

from harness.planning.world import ATTACH_OFFSET, PlanningWorld
from harness.sim.masks import TABLE_BIT, refresh_body_masks
from harness.sim.queries import T_from_pos_mat
from harness.sim.scene import Scene

Phase = Literal["transport", "approach", "carry"]


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
        self.moving_all = scene.robot_geom & ~scene.static_robot_geom
        self.moving = self.moving_all
        # The planned arm's geoms (its base body's subtree): its self-collision model.
        self.arm_geom = scene.geom_arm == list(scene.arms).index(arm)
        self.robot_pairs_all = True
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
        self.attach_target = False
        self.target_qpos_adr = -1
        self.target_qpos0 = np.zeros(7)
        self.T_ee_target: np.ndarray | None = None  # the attached target in the EE frame

    def sync(self, world: PlanningWorld) -> None:
        """Copy the scene's current state (robot root, all joints, objects) into the checker and
        take ``world`` as the planning world.

        ``table_clearance`` (m) makes coming closer than that to the table a collision.
        ``ignore_substring`` leaves every other object whose name contains one of the
        substrings out of the planning world (the pick's ``ignore_substring``, the reference
        planner's ignore list); the target object follows ``check_target`` alone.

        ``check_table`` False leaves the table out of the planning world (the reference's
        default ignore list holds it); ``check_target`` False leaves the target object
        out (the reference removes it before testing and planning the pre-grasp and the grasp,
        docs/reference-pick-skill.md section 6 step 2).
        Contacts present in the current state (a first
        link standing in the table top, two links of a noisy home posture touching) are where
        the robot already is, not planning failures: those pairs are allowed for the queries
        that follow.
        """
        table = self.scene.table_geom
        bits = TABLE_BIT if world.check_table else 0
        self.model.geom_contype[table] = bits
        self.model.geom_conaffinity[table] = bits
        self.model.geom_margin[table] = world.table_clearance
        self.table_clearance = world.table_clearance
        refresh_body_masks(self.model)
        self.check_table = world.check_table
        self.check_target = world.check_target
        self.attach_target = world.attach_target
        self.T_ee_target = None
        self.robot_pairs_all = world.whole_robot
        self.moving = self.moving_all if world.whole_robot else self.moving_all & self.arm_geom
        src, dst = self.scene.data, self.data
        dst.qpos[:] = src.qpos
        dst.mocap_pos[:] = src.mocap_pos
        dst.mocap_quat[:] = src.mocap_quat
        self.target_index = self.scene.object_names.index(world.target)
        target = self.scene.objects[world.target]
        self.target_qpos_adr = target.qpos_adr
        self.target_qpos0 = src.qpos[target.qpos_adr : target.qpos_adr + 7].copy()
        ignored = [
            index
            for index, name in enumerate(self.scene.object_names)
            if index != self.target_index and any(part in name for part in world.ignore_substring)
        ]
        self.ignored_geom = np.isin(self.geom_object, ignored) & (self.geom_object >= 0)
        self.allowed = set()
        q_now = src.qpos[self.handles.active_qpos].copy()
        self.allowed = set(self.contacts(q_now, "transport"))

    def attach(self, q_grasp: np.ndarray) -> None:
        """Attach the target to the hand at the grasp configuration ``q_grasp`` for the carry
        (``PlanningWorld.attach_target``): its pose in the EE frame, taken as if it lay
        ``ATTACH_OFFSET`` higher along the arm base's z (the reference's ``attach_obj``)."""
        if not self.attach_target:
            return
        m, d = self.model, self.data
        d.qpos[self.target_qpos_adr : self.target_qpos_adr + 7] = self.target_qpos0
        d.qpos[self.handles.active_qpos] = q_grasp
        mujoco.mj_kinematics(m, d)
        T_world_ee = _body_T(d, self.handles.ee_body)
        base_z = d.xmat[self.handles.base_body].reshape(3, 3)[:, 2]
        T_world_ee[:3, 3] -= ATTACH_OFFSET * base_z  # offset^-1 * T_world_ee
        T_world_target = _body_T(
            d, self.scene.objects[self.scene.object_names[self.target_index]].body_id
        )
        self.T_ee_target = np.linalg.inv(T_world_ee) @ T_world_target

    def detach(self) -> None:
        """The target lies where it was synced (the transport and approach planning world)."""
        self.T_ee_target = None

    def _place_target(self, carried: bool) -> None:
        """Put the target where this query sees it: in the hand for an attached carry (the EE
        pose must be current in ``data``), else where it was synced."""
        d = self.data
        adr = self.target_qpos_adr
        if adr < 0:
            return
        if carried and self.T_ee_target is not None:
            T = _body_T(d, self.handles.ee_body) @ self.T_ee_target
            body = self.scene.objects[self.scene.object_names[self.target_index]].body_id
            # The free joint's qpos is its body's pose when the body has no offset frame.
            T_body_joint = np.linalg.inv(_body_T(d, body)) @ _qpos_T(d.qpos[adr : adr + 7])
            T = T @ T_body_joint
            d.qpos[adr : adr + 3] = T[:3, 3]
            quat = np.empty(4)
            mujoco.mju_mat2Quat(quat, T[:3, :3].reshape(-1))
            d.qpos[adr + 3 : adr + 7] = quat
        else:
            d.qpos[adr : adr + 7] = self.target_qpos0

    def contacts(
        self, q_active: np.ndarray, phase: Phase, tolerance: float | None = None
    ) -> list[tuple[int, int]]:
        """Offending (geom, geom) pairs at ``q_active`` for ``phase``: penetrating deeper than
        ``tolerance`` (default: the checker's planning tolerance)."""
        m, d = self.model, self.data
        d.qpos[self.handles.active_qpos] = q_active
        carried = phase == "carry" and self.attach_target and self.T_ee_target is not None
        if self.target_qpos_adr >= 0 and self.attach_target:
            if carried:
                mujoco.mj_kinematics(m, d)
            self._place_target(carried)
        mujoco.mj_kinematics(m, d)
        mujoco.mj_collision(m, d)
        self.checks += 1
        ncon = d.ncon
        if ncon == 0:
            return []
        limit = -(self.tolerance if tolerance is None else tolerance)
        geoms = d.contact.geom[:ncon].tolist()
        dists = d.contact.dist[:ncon].tolist()
        return [
            (a, b)
            for (a, b), dist in zip(geoms, dists, strict=True)
            if self._offends(a, b, dist, limit, phase, carried) and (a, b) not in self.allowed
        ]

    def _offends(
        self, a: int, b: int, dist: float, limit: float, phase: Phase, carried: bool
    ) -> bool:
        """Whether the contact of geoms ``a`` and ``b`` at distance ``dist`` is a collision for
        ``phase`` (module doc). One contact at a time in Python: a query has a few contacts,
        and whole-array numpy on so few costs more than the loop."""
        table = self.scene.table_geom
        if self.table_clearance > 0.0 and (a == table or b == table):
            limit = self.table_clearance
        if not dist < limit:  # not deep enough to count
            return False
        robot, moving, ignored = self.robot, self.moving, self.ignored_geom
        env_hit = (moving[a] and not robot[b]) or (moving[b] and not robot[a])
        if phase == "approach" and self.check_target and self._on_target(self.finger, a, b):
            env_hit = False  # the fingers may touch the target object
        if (phase == "carry" or not self.check_target) and self._on_target(robot, a, b):
            env_hit = False  # nothing of the robot is checked against the target
        if ignored[a] or ignored[b]:
            env_hit = False
        if self.robot_pairs_all:
            robot_pair = robot[a] and robot[b]
        else:  # the planned arm's self-collision model only
            robot_pair = self.arm_geom[a] and self.arm_geom[b]
        if env_hit or robot_pair:
            return True
        return carried and self._target_meets_world(a, b)

    def _on_target(self, part: np.ndarray, a: int, b: int) -> bool:
        """One geom of the pair is the target object's, the other in ``part`` (a geom mask)."""
        obj, target = self.geom_object, self.target_index
        return bool((part[a] and obj[b] == target) or (part[b] and obj[a] == target))

    def _target_meets_world(self, a: int, b: int) -> bool:
        """One geom of the pair is the target object's, the other the world's (not the robot's,
        an ignored object's or the target's): the attached target's collisions in a carry."""
        obj, target = self.geom_object, self.target_index
        for mine, other in ((a, b), (b, a)):
            world = not (self.robot[other] or self.ignored_geom[other] or obj[other] == target)
            if obj[mine] == target and world:
                return True
        return False

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

    def pair_names(self, pair: tuple[int, int]) -> tuple[str, str]:
        """The bodies of a colliding (geom, geom) pair, by name (as ``describe`` writes them)."""
        m = self.model
        a, b = pair
        return m.body(int(m.geom_bodyid[a])).name, m.body(int(m.geom_bodyid[b])).name

    def describe(self, pairs: list[tuple[int, int]]) -> str:
        m = self.model
        return ", ".join(
            f"{m.body(int(m.geom_bodyid[a])).name}/{m.body(int(m.geom_bodyid[b])).name}"
            for a, b in pairs
        )


def _body_T(data: mujoco.MjData, body: int) -> np.ndarray:
    return T_from_pos_mat(data.xpos[body], data.xmat[body])


def _qpos_T(qpos: np.ndarray) -> np.ndarray:
    """A free joint's 7 qpos values (position, wxyz) as a 4x4 transform."""
    mat = np.empty(9)
    mujoco.mju_quat2Mat(mat, np.asarray(qpos[3:7], dtype=float))
    return T_from_pos_mat(qpos[:3], mat)


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
