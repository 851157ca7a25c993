"""State and contact queries of a scene: poses, velocities, finger forces, robot contacts.

:class:`SceneQueries` is the read-only half of :class:`harness.sim.scene.Scene` (a base class
it inherits from): everything here reads ``data`` after MuJoCo has computed it and changes
nothing in the simulation.
"""

from __future__ import annotations

import mujoco
import numpy as np

from harness.errors import HarnessError
from harness.sim.index import ArmHandles, SceneObject, body_subtree
from harness.transforms import invert_T


def T_from_pos_mat(pos: np.ndarray, xmat: np.ndarray) -> np.ndarray:
    """The 4x4 pose of a MuJoCo position and flat rotation matrix (``zeros`` and one 1 costs
    half of ``np.eye``: this runs every control step)."""
    T = np.zeros((4, 4))
    T[3, 3] = 1.0
    T[:3, :3] = np.asarray(xmat).reshape(3, 3)
    T[:3, 3] = pos
    return T


class SceneQueries:
    """Queries on the scene's current MuJoCo state (the fields are :class:`Scene`'s)."""

    objects: dict[str, SceneObject]
    model: mujoco.MjModel
    data: mujoco.MjData
    root_body: int
    arms: dict[str, ArmHandles]
    robot_geom: np.ndarray
    static_robot_geom: np.ndarray
    geom_object: np.ndarray
    object_names: tuple[str, ...]
    robot_dof: np.ndarray
    _tmp_force: np.ndarray

    def T_world_body(self, body: int) -> np.ndarray:
        d = self.data
        return T_from_pos_mat(d.xpos[body], d.xmat[body])

    def T_world_frame(self, name: str) -> np.ndarray:
        """World pose of a body (URDF link) or site, by name."""
        m = self.model
        bid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)
        if bid >= 0:
            return self.T_world_body(bid)
        sid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, name)
        if sid >= 0:
            return T_from_pos_mat(self.data.site_xpos[sid], self.data.site_xmat[sid])
        raise HarnessError(f"no body or site named {name!r} in the scene")

    def T_world_base(self, arm: str) -> np.ndarray:
        return self.T_world_body(self.arms[arm].base_body)

    def T_base_frame(self, arm: str, name: str) -> np.ndarray:
        """Pose of a frame in the arm base frame (the planning and filter frame)."""
        return invert_T(self.T_world_base(arm)) @ self.T_world_frame(name)

    def T_base_ee(self, arm: str) -> np.ndarray:
        handles = self.arms[arm]
        return invert_T(self.T_world_body(handles.base_body)) @ self.T_world_body(handles.ee_body)

    def T_world_root(self) -> np.ndarray:
        return self.T_world_body(self.root_body)

    def T_world_object(self, name: str) -> np.ndarray:
        return self.T_world_body(self.objects[name].body_id)

    def object_velocity(self, name: str) -> np.ndarray:
        """Linear (world, m/s) and angular velocity of an object, (6,)."""
        obj = self.objects[name]
        if obj.fixed:
            return np.zeros(6)
        return self.data.qvel[obj.dof_adr : obj.dof_adr + 6].copy()

    def active_q(self, arm: str) -> np.ndarray:
        return self.data.qpos[self.arms[arm].active_qpos].copy()

    def gripper_opening(self, arm: str) -> float:
        """Mean per-finger opening (m); the gripper width is twice this."""
        return float(np.mean(self.data.qpos[self.arms[arm].finger_qpos]))

    def robot_joint_speed(self) -> float:
        """max |qvel| over every robot joint (rad/s or m/s)."""
        return float(np.max(np.abs(self.data.qvel[self.robot_dof]))) if len(self.robot_dof) else 0.0

    def finger_forces(self, arm: str, object_name: str) -> tuple[float, float]:
        """Summed contact normal force (N) between each finger of ``arm`` and the object."""
        d, m = self.data, self.model
        ncon = d.ncon
        if ncon == 0:
            return 0.0, 0.0
        geoms = d.contact.geom[:ncon]
        side = self.arms[arm].finger_geom_side
        obj_index = self.object_names.index(object_name)
        obj = self.geom_object
        forces = [0.0, 0.0]
        g1, g2 = geoms[:, 0], geoms[:, 1]
        hits = np.flatnonzero(
            ((side[g1] >= 0) & (obj[g2] == obj_index)) | ((side[g2] >= 0) & (obj[g1] == obj_index))
        )
        f6 = self._tmp_force
        for i in hits:
            mujoco.mj_contactForce(m, d, int(i), f6)
            finger = side[g1[i]] if side[g1[i]] >= 0 else side[g2[i]]
            forces[int(finger)] += abs(float(f6[0]))
        return forces[0], forces[1]

    def finger_contacts(
        self, arm: str, object_name: str
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The contacts between the fingers of ``arm`` and the object: world points (k, 3),
        the contact force on the object in world coordinates (k, 3, N; normal and friction),
        and the finger of each (k,: 0 left, 1 right)."""
        d, m = self.data, self.model
        ncon = d.ncon
        if ncon == 0:
            return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
        geoms = d.contact.geom[:ncon]
        side = self.arms[arm].finger_geom_side
        obj = self.geom_object
        obj_index = self.object_names.index(object_name)
        g1, g2 = geoms[:, 0], geoms[:, 1]
        object_second = (side[g1] >= 0) & (obj[g2] == obj_index)
        object_first = (side[g2] >= 0) & (obj[g1] == obj_index)
        hits = np.flatnonzero(object_second | object_first)
        if not len(hits):
            return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
        contact = d.contact  # one struct view: each attribute access copies the whole buffer
        points = contact.pos[hits]
        frames = contact.frame[hits].reshape(-1, 3, 3)
        local = np.zeros((len(hits), 3))
        f6 = self._tmp_force
        for k, i in enumerate(hits.tolist()):
            mujoco.mj_contactForce(m, d, i, f6)
            local[k] = f6[:3]
        # The frame's rows are (normal, tangent, tangent); the force acts on geom2 along
        # +normal (geom1 -> geom2), so on the object it flips when the object is geom1.
        sign = np.where(object_second[hits], 1.0, -1.0)[:, None]
        forces = np.einsum("kji,kj->ki", frames, local) * sign
        fingers = np.where(object_second[hits], side[g1[hits]], side[g2[hits]]).astype(np.int64)
        return points, forces, fingers

    def robot_contacts(self, arm: str | None = None) -> list[tuple[str, str]]:
        """Contacts of the robot with the environment (table, objects) and with itself across
        arms, as (robot body, other body) name pairs; finger-object contacts of ``arm`` and
        contacts of the robot's static parts are left out."""
        return [
            (self.model.body(a).name, self.model.body(b).name)
            for a, b in self.robot_contact_bodies(arm)
        ]

    def robot_contact_bodies(self, arm: str | None = None) -> list[tuple[int, int]]:
        d, m = self.data, self.model
        ncon = d.ncon
        if ncon == 0:
            return []
        geoms = d.contact.geom[:ncon]
        g1, g2 = geoms[:, 0], geoms[:, 1]
        robot = self.robot_geom
        moving = robot & ~self.static_robot_geom
        involved = (moving[g1] | moving[g2]) & ~(robot[g1] & robot[g2] & ~self._cross_arm(g1, g2))
        if arm is not None:
            side = self.arms[arm].finger_geom_side
            finger_object = ((side[g1] >= 0) & (self.geom_object[g2] >= 0)) | (
                (side[g2] >= 0) & (self.geom_object[g1] >= 0)
            )
            involved &= ~finger_object
        out = []
        for i in np.flatnonzero(involved):
            a, b = int(g1[i]), int(g2[i])
            if not robot[a]:
                a, b = b, a
            out.append((int(m.geom_bodyid[a]), int(m.geom_bodyid[b])))
        return out

    def _cross_arm(self, g1: np.ndarray, g2: np.ndarray) -> np.ndarray:
        """True where two robot geoms belong to different arms' subtrees."""
        owner = self.geom_arm
        return (owner[g1] >= 0) & (owner[g2] >= 0) & (owner[g1] != owner[g2])

    @property
    def geom_arm(self) -> np.ndarray:
        """(ngeom,) index of the arm (in ``arms`` order) whose subtree holds each geom, or -1."""
        cached = getattr(self, "_geom_arm_cache", None)
        if cached is None:
            cached = np.full(self.model.ngeom, -1, dtype=np.int64)
            for index, handles in enumerate(self.arms.values()):
                for body in body_subtree(self.model, handles.base_body):
                    cached[self.model.geom_bodyid == body] = index
            self._geom_arm_cache = cached
        return cached
