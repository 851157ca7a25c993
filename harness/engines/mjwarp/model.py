"""A task model on a Warp device: its ``mjw.Model`` and the constant inputs of the signal
kernels (which robot dofs, which finger geoms, the target object, the table slab), made once per
(task model, arm, target) and shared by the lockstep batches, the lanes and the tug rounds."""

from __future__ import annotations

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
        handles = scene.arms[task.arm]
        obj = scene.objects[task.target_object.name]
        with wp.ScopedDevice(device):
            self.model = mjw.put_model(m)
            self.robot_dof = wp.array(scene.robot_dof.astype(np.int32), dtype=wp.int32)
            self.finger_side = wp.array(handles.finger_geom_side.astype(np.int32), dtype=wp.int32)
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
        self.ee_body = int(handles.ee_body)
        self.tcp_body = int(handles.tcp_body)
        self.weight = float(m.body_subtreemass[obj.body_id]) * float(np.linalg.norm(m.opt.gravity))

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
    ) -> None:
        """Launch the signal kernels for the current state: each world ``w`` of ``d`` whose
        ``row_of[w]`` is a row writes ``out[world_of[w], row]``; one whose row is
        ``kernels.BASELINE`` writes ``start_out[world_of[w], 0]``, the start the table
        penetration is counted from (``TablePenetration.depth``'s first call; its penetration
        is 0); ``kernels.NO_ROW``: nothing."""
        wp.launch(
            kernels.record, dim=d.nworld,
            inputs=[
                d.qpos, d.qvel, d.xpos, d.xmat, d.geom_xpos, d.geom_xmat, self.robot_dof,
                self.obj_body, self.obj_dof, self.ee_body, self.tcp_body, self.pen_geom,
                self.pen_box, self.pen_radial, self.pen_round, self.pen_offset, self.table,
                self.table_half, pen_initial, row_of, world_of, out, start_out,
            ],
        )  # fmt: skip
        wp.launch(
            kernels.finger_forces, dim=d.naconmax,
            inputs=[
                d.nacon, d.contact.geom, d.contact.worldid, d.contact.efc_address, d.efc.force,
                self.finger_side, self.object_geom, row_of, world_of, out, start_out,
            ],
        )  # fmt: skip
