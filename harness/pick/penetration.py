"""How deep the robot is inside the table slab, measured from the geometry (``TablePenetration``).

Robot-table contact may be off in the physics (the reference's ``neglect_collision_names:
[table]``), so MuJoCo's contacts cannot say how far a finger went into the table. This module
asks MuJoCo's own distance query instead (``mj_geomDistance``, which ignores the contact
filters): the signed distance between each moving robot collision geom and the table's slab,
negative inside it. Any geom counts, wherever its centre is: a finger pad whose centre is past
the table's edge but whose corner is in the slab is inside it, and a lift carriage standing
beside the slab, below the table top but not in the slab, is not.

The depth counted is how much deeper than at the start of the motion (the first ``depth``
call) a geom is: a part that already stood in the slab before the pick moved anything (the
Lift-2 carriage, held by the lift 4.1 mm into the slab's edge at the reference placement of
this model) is a fact of the placement, not of the pick's motion; ``initial`` keeps it.

To keep it cheap (a few microseconds per control step for ~30 geoms), the distance is asked
only of geoms whose lowest point lies below the table top and whose bounding box overlaps the
slab's footprint; the lowest point of a geom with rotation ``R`` (world from geom) is its centre
minus its extent along world z: ``sum_j |R[2, j]| h_j`` for a box of half sizes ``h``,
``|R[2, 2]| h + r`` for a capsule, ``|R[2, 2]| h + r sqrt(1 - R[2, 2]^2)`` for a cylinder, ``r``
for a sphere (the geom's bounding box for anything else).
"""

from __future__ import annotations

import mujoco
import numpy as np

from harness.sim import TABLE_NAME, Scene

# Distances beyond this are not asked for (m): only the inside of the slab matters.
DISTANCE_MAX = 0.01


class TablePenetration:
    """How deep any moving robot collision geom is inside the table slab (m, >= 0)."""

    def __init__(self, scene: Scene) -> None:
        m = scene.model
        self.model = m
        collides = (m.geom_contype != 0) | (m.geom_conaffinity != 0)
        self.geoms = np.flatnonzero(scene.robot_geom & ~scene.static_robot_geom & collides)
        table = m.geom(TABLE_NAME).id
        self.table = table
        self.initial: np.ndarray | None = None  # per geom: how deep it was at the start (m)
        # The table geom sits in the world body: its model pose is its world pose.
        self.table_top = float(m.geom_pos[table][2] + m.geom_size[table][2])
        self.table_xy = m.geom_pos[table][:2].copy()
        self.table_half_xy = m.geom_size[table][:2].copy()
        n = len(self.geoms)
        types = m.geom_type[self.geoms]
        size = m.geom_size[self.geoms]
        self.box_half = np.zeros((n, 3))  # extent = sum |R[2, j]| * box_half_j
        self.radial = np.zeros(n)  # + radial * sqrt(1 - R[2, 2]^2)  (cylinder rims)
        self.round = np.zeros(n)  # + round  (sphere, capsule radius)
        self.offset = np.zeros((n, 3))  # bounding-box centre in the geom frame
        for i, (kind, s) in enumerate(zip(types, size, strict=True)):
            if kind == mujoco.mjtGeom.mjGEOM_BOX:
                self.box_half[i] = s
            elif kind == mujoco.mjtGeom.mjGEOM_SPHERE:
                self.round[i] = s[0]
            elif kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
                self.box_half[i, 2], self.round[i] = s[1], s[0]
            elif kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
                self.box_half[i, 2], self.radial[i] = s[1], s[0]
            else:  # mesh, ellipsoid, ...: the geom's local bounding box
                aabb = m.geom_aabb[self.geoms[i]]
                self.offset[i], self.box_half[i] = aabb[:3], aabb[3:]

    def depth(self, data: mujoco.MjData) -> float:
        """Penetration depth now (m): how much deeper than at the first call the deepest robot
        geom is inside the table slab (0 when none went deeper)."""
        if len(self.geoms) == 0:
            return 0.0
        inside = self._inside(data)
        if self.initial is None:
            self.initial = inside
        return float(np.max(inside - self.initial, initial=0.0))

    def deepest(self, data: mujoco.MjData) -> tuple[float, int, np.ndarray]:
        """(``depth`` now, the deepest geom's id or -1, the middle of its overlap with the slab
        in world): what a viewer marks for a finger through the table."""
        depth = self.depth(data)
        if depth <= 0.0 or self.initial is None:
            return depth, -1, np.zeros(3)
        k = int(np.argmax(self._inside(data) - self.initial))
        geom = int(self.geoms[k])
        fromto = np.zeros(6)
        mujoco.mj_geomDistance(self.model, data, geom, self.table, DISTANCE_MAX, fromto)
        return depth, geom, (fromto[:3] + fromto[3:]) / 2.0

    def _inside(self, data: mujoco.MjData) -> np.ndarray:
        """Per moving robot geom: how deep it is inside the table slab now (m, >= 0)."""
        pos = data.geom_xpos[self.geoms]
        z_axes = data.geom_xmat[self.geoms][:, 6:9]  # row 2 of R: world z of each local axis
        centre_z = pos[:, 2] + np.einsum("ij,ij->i", z_axes, self.offset)
        cos_z = np.minimum(np.abs(z_axes[:, 2]), 1.0)
        extent = (
            np.einsum("ij,ij->i", np.abs(z_axes), self.box_half)
            + self.radial * np.sqrt(1.0 - cos_z * cos_z)
            + self.round
        )
        low = centre_z - extent < self.table_top
        # Bounding radius in the horizontal plane: the geom can reach the slab's footprint.
        reach = self.model.geom_rbound[self.geoms]
        near = np.all(
            np.abs(pos[:, :2] - self.table_xy) <= self.table_half_xy + reach[:, None], axis=1
        )
        inside = np.zeros(len(self.geoms))
        for k in np.flatnonzero(low & near):
            distance = mujoco.mj_geomDistance(
                self.model, data, int(self.geoms[k]), self.table, DISTANCE_MAX, None
            )
            inside[k] = max(0.0, -distance)
        return inside
