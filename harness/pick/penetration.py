"""How deep the robot is inside the table top, measured geometrically (``TablePenetration``).

Robot-table contact may be off in the physics (the reference's ``neglect_collision_names:
[table]``), so MuJoCo's contacts cannot say how far a finger went into the table. This module
computes it from the geoms' poses and sizes instead: for every moving robot collision geom, the
lowest point of the geom in world z, exactly for the primitives the robots use (sphere, capsule,
cylinder, box) and from the geom's bounding box for anything else (mesh, ellipsoid); the depth is
how far that point lies below the table's top face, counted only for geoms whose centre is above
the table's footprint. One vectorised pass over ~30 geoms per control step (a few microseconds),
where ``mj_geomDistance`` against the table would cost a collision test per geom.

The lowest point of a geom with rotation ``R`` (world from geom) is its centre minus its extent
along world z: ``sum_j |R[2, j]| h_j`` for a box of half sizes ``h``, ``|R[2, 2]| h + r`` for a
capsule, ``|R[2, 2]| h + r sqrt(1 - R[2, 2]^2)`` for a cylinder, ``r`` for a sphere.
"""

from __future__ import annotations

import mujoco
import numpy as np

from harness.sim import TABLE_NAME, Scene


class TablePenetration:
    """The deepest point of any moving robot collision geom below the table top (m, >= 0)."""

    def __init__(self, scene: Scene) -> None:
        m = scene.model
        collides = (m.geom_contype != 0) | (m.geom_conaffinity != 0)
        self.geoms = np.flatnonzero(scene.robot_geom & ~scene.static_robot_geom & collides)
        table = m.geom(TABLE_NAME).id
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
        """Penetration depth now (m): 0 when every geom over the table is above its top."""
        return self.deepest(data)[0]

    def deepest(self, data: mujoco.MjData) -> tuple[float, int, np.ndarray]:
        """(depth now in m, the deepest geom's id or -1, its lowest point in world): what a
        viewer marks for a finger through the table."""
        none = (0.0, -1, np.zeros(3))
        if len(self.geoms) == 0:
            return none
        pos = data.geom_xpos[self.geoms]
        z_axes = data.geom_xmat[self.geoms][:, 6:9]  # row 2 of R: world z of each local axis
        centre_z = pos[:, 2] + np.einsum("ij,ij->i", z_axes, self.offset)
        cos_z = np.minimum(np.abs(z_axes[:, 2]), 1.0)
        extent = (
            np.einsum("ij,ij->i", np.abs(z_axes), self.box_half)
            + self.radial * np.sqrt(1.0 - cos_z * cos_z)
            + self.round
        )
        over = np.all(np.abs(pos[:, :2] - self.table_xy) <= self.table_half_xy, axis=1)
        if not over.any():
            return none
        lowest = np.where(over, centre_z - extent, np.inf)
        k = int(np.argmin(lowest))
        point = np.array([pos[k, 0], pos[k, 1], lowest[k]])
        return max(0.0, self.table_top - float(lowest[k])), int(self.geoms[k]), point
