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
  is checked against the target object.

What the planning world holds is set per episode (``sync``, a ``PlanningWorld`` that
``harness.pick.semantics.Semantics.planning_world`` decides): the table (out under reference
semantics, as the reference's default ignore list leaves it out, quirk 21; in under strict) and
the target object (always in; the reference removes it while planning the pre-grasp and the
grasp, docs/reference-pick-skill.md section 6).
"""

from __future__ import annotations

from typing import Literal

import mujoco
import numpy as np

from harness.planning.world import PlanningWorld
from harness.sim.masks import TABLE_BIT, refresh_body_masks
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
        src, dst = self.scene.data, self.data
        dst.qpos[:] = src.qpos
        dst.mocap_pos[:] = src.mocap_pos
        dst.mocap_quat[:] = src.mocap_quat
        self.target_index = self.scene.object_names.index(world.target)
        ignored = [
            index
            for index, name in enumerate(self.scene.object_names)
            if index != self.target_index and any(part in name for part in world.ignore_substring)
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
