"""The gripper's collision test of the grasp generator: GraspNet's finger and palm boxes of a
grasp row against the mesh, exactly (coal, the FCL successor placo already installs)."""

from __future__ import annotations

import numpy as np
import trimesh

from harness.objects.graspgen.model import GripperModel


class GripperCollision:
    """Exact gripper-box versus mesh collision with coal (BVH over the triangles)."""

    def __init__(self, mesh: trimesh.Trimesh) -> None:
        import coal

        self._coal = coal
        bvh = coal.BVHModelOBBRSS()
        bvh.beginModel(len(mesh.faces), len(mesh.vertices))
        bvh.addVertices(np.asarray(mesh.vertices, dtype=np.float64))
        bvh.addTriangles(np.asarray(mesh.faces, dtype=np.int32))
        bvh.endModel()
        self.bvh = bvh
        self.identity = coal.Transform3s()
        self.request = coal.CollisionRequest()
        self.result = coal.CollisionResult()

    def box_hits(self, rotation: np.ndarray, centre: np.ndarray, size: np.ndarray) -> bool:
        """True when the box (object-frame rotation and centre, full size) touches a triangle."""
        coal = self._coal
        self.result.clear()
        box = coal.Box(float(size[0]), float(size[1]), float(size[2]))
        pose = coal.Transform3s(rotation, centre)
        return bool(coal.collide(self.bvh, self.identity, box, pose, self.request, self.result))


def grasp_boxes(
    grasp: np.ndarray, gripper: GripperModel, inner_half_width: float
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Object-frame (rotation, centre, size) of the gripper boxes of one N x 17 row."""
    rotation = np.asarray(grasp[4:13], dtype=np.float64).reshape(3, 3)
    translation = np.asarray(grasp[13:16], dtype=np.float64)
    return [
        (rotation, translation + rotation @ centre, size)
        for centre, size in gripper.boxes(float(grasp[1]), float(grasp[3]), inner_half_width)
    ]


# --------------------------------------------------------------------------------------------
