"""A task model on a Warp device: its ``mjw.Model`` and the constant inputs of the signal
kernels (which robot dofs, each arm's end effector and finger geoms, the target object, the table
slab), made once per (task model, target) and shared by the lockstep batches, the lanes and the
tug rounds. Both arms of a two-arm robot share it: each world records its own job's arm
(``arm_of``), so one lane stream serves a scene's left and right picks."""

from __future__ import annotations

from collections.abc import Sequence

import mujoco_warp as mjw
import numpy as np
import warp as wp

from harness.config import TaskConfig
from harness.engines.mjwarp import kernels, noslip
from harness.pick.penetration import TablePenetration
from harness.sim import Scene

noslip.install()  # the noslip pass with a block per world (harness.engines.mjwarp.noslip)


class DeviceModel:
    """A task model on a Warp device, with the constant inputs of the signal kernels."""

    def __init__(self, scene: Scene, task: TaskConfig, device: str) -> None:
        m = scene.model
        self.mj_model = m
        self.template = scene.data
        self.device = device
        self.arms = list(scene.arms)  # an arm's index in the per-arm arrays
        arms = [scene.arms[name] for name in self.arms]
        obj = scene.objects[task.target_object.name]
        with wp.ScopedDevice(device):
            self.model = mjw.put_model(m)
            self.robot_dof = wp.array(scene.robot_dof.astype(np.int32), dtype=wp.int32)
            sides = np.stack([h.finger_geom_side for h in arms]).astype(np.int32)
            self.finger_side = wp.array(sides, dtype=wp.int32)  # (arm, geom)
            self.ee_body = wp.array([int(h.ee_body) for h in arms], dtype=wp.int32)
            self.tcp_body = wp.array([int(h.tcp_body) for h in arms], dtype=wp.int32)
            geom_object = scene.geom_object == scene.object_names.index(obj.name)
            self.object_geom = wp.array(geom_object.astype(np.int32), dtype=wp.int32)
            pen = TablePenetration(scene)
            self.pen_geom = wp.array(pen.geoms.astype(np.int32), dtype=wp.int32)
            self.pen_box = wp.array(pen.box_half.astype(np.float32), dtype=wp.vec3)
            self.pen_radial = wp.array(pen.radial.astype(np.float32), dtype=wp.float32)
            self.pen_round = wp.array(pen.round.astype(np.float32), dtype=wp.float32)
            self.pen_offset = wp.array(pen.offset.astype(np.float32), dtype=wp.vec3)
        # The table geom sits in the world body: its model pose is its world pose (an unrotated
        # box: its face normals are the world axes).
        self.table = wp.vec3(*(float(v) for v in m.geom_pos[pen.table]))
        self.table_half = wp.vec3(*(float(v) for v in m.geom_size[pen.table]))
        self.pen_count = len(pen.geoms)
        self.obj_body = int(obj.body_id)
        self.obj_dof = int(obj.dof_adr)
        self.weight = float(m.body_subtreemass[obj.body_id]) * float(np.linalg.norm(m.opt.gravity))

    def arm_index(self, arm: str) -> int:
        """``arm``'s index in the per-arm arrays (``arm_of``'s values)."""
        return self.arms.index(arm)

    def arms_of(self, arms: Sequence[str]) -> wp.array:
        """Each arm name's index, on the device: an ``arm_of`` for ``record``."""
        index = np.asarray([self.arm_index(arm) for arm in arms], dtype=np.int32)
        return wp.array(index, dtype=wp.int32, device=self.device)

    def penetration_start(self, nworld: int) -> wp.array:
        """Per world and geom, how deep it is in the slab at the start (filled by ``record``
        with ``baseline``)."""
        return wp.zeros((nworld, max(1, self.pen_count)), dtype=wp.float32, device=self.device)

    def record(
        self,
        d: mjw.Data,
        row_of: wp.array,
        out: wp.array,
        start_out: wp.array,
        pen_initial: wp.array,
        world_of: wp.array,
        arm_of: wp.array,
    ) -> None:
        """Launch the signal kernels for the current state: each world ``w`` of ``d`` whose
        ``row_of[w]`` is a row writes ``out[world_of[w], row]``; one whose row is
        ``kernels.BASELINE`` writes ``start_out[world_of[w], 0]``, the start the table
        penetration is counted from (``TablePenetration.depth``'s first call; its penetration
        is 0); ``kernels.NO_ROW``: nothing. ``arm_of[b]``: batch world ``b``'s arm."""
        wp.launch(
            kernels.record, dim=d.nworld,
            inputs=[
                d.qpos, d.qvel, d.xpos, d.xmat, d.geom_xpos, d.geom_xmat, self.robot_dof,
                self.obj_body, self.obj_dof, self.ee_body, self.tcp_body, self.pen_geom,
                self.pen_box, self.pen_radial, self.pen_round, self.pen_offset, self.table,
                self.table_half, pen_initial, row_of, world_of, arm_of, out, start_out,
            ],
        )  # fmt: skip
        wp.launch(
            kernels.finger_forces, dim=d.naconmax,
            inputs=[
                d.nacon, d.contact.geom, d.contact.worldid, d.contact.efc_address, d.efc.force,
                self.finger_side, self.object_geom, row_of, world_of, arm_of, out, start_out,
            ],
        )  # fmt: skip
