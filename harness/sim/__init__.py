"""Simulation: the MuJoCo scene of one robot, a table and a task's objects.

``composition`` builds and compiles the model, ``index`` maps names to MuJoCo addresses,
``masks`` holds the collision bits, ``queries`` reads poses and contacts, and ``scene`` is the
:class:`Scene` runtime (reset, placement, stepping).
"""

from harness.sim.composition import TABLE_NAME, scene_key, with_object_defaults
from harness.sim.index import ArmHandles, SceneObject
from harness.sim.masks import ROBOT_BIT, TABLE_BIT, refresh_body_masks
from harness.sim.scene import ResetState, Scene

__all__ = [
    "ROBOT_BIT",
    "TABLE_BIT",
    "TABLE_NAME",
    "ArmHandles",
    "ResetState",
    "Scene",
    "SceneObject",
    "refresh_body_masks",
    "scene_key",
    "with_object_defaults",
]
