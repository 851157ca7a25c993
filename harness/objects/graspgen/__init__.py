"""Antipodal grasp annotations for any mesh, in the GraspNet / InternDataEngine N x 17 layout.

One concept per module: ``model`` (the file layout, the gripper boxes, the settings),
``contacts`` (surface samples, patch normals, ray casts, force closure), ``collision`` (the
gripper boxes against the mesh), ``generate`` (the algorithm: sample pairs, score, approach,
collision-check; its docstring states the convention and the steps).
"""

from harness.objects.graspgen.collision import GripperCollision, grasp_boxes
from harness.objects.graspgen.contacts import (
    ContactNormals,
    RayCaster,
    force_closure_score,
    sample_surface,
)
from harness.objects.graspgen.generate import generate_grasps
from harness.objects.graspgen.model import (
    DEPTHS,
    FRICTION_LEVELS,
    GRASP_HEIGHT,
    GraspAnnotations,
    GraspGenParams,
    GripperModel,
    save_grasps,
)

__all__ = [
    "DEPTHS",
    "FRICTION_LEVELS",
    "GRASP_HEIGHT",
    "ContactNormals",
    "GraspAnnotations",
    "GraspGenParams",
    "GripperCollision",
    "GripperModel",
    "RayCaster",
    "force_closure_score",
    "generate_grasps",
    "grasp_boxes",
    "sample_surface",
    "save_grasps",
]
