"""Collision bit masks of the scene and the per-body mask refresh after changing them.

Contact switch: the table geom uses contype/conaffinity bit 1 (value 2); objects carry bits 0
and 1; robot geoms carry bit 1 only when ``physics.table_contact`` is on (the reference turns
robot-table contact off with ``neglect_collision_names: [table]``). The planner's collision
checker flips the table bits at run time, hence :func:`refresh_body_masks`.
"""

from __future__ import annotations

import mujoco
import numpy as np

TABLE_BIT = 2  # contype / conaffinity bit of the table
ROBOT_BIT = 1


def refresh_body_masks(model: mujoco.MjModel) -> None:
    """Recompute the per-body contype / conaffinity (the OR over each body's geoms) after
    changing geom masks at run time: MuJoCo's broad phase filters body pairs with them."""
    contype = np.zeros(model.nbody, dtype=np.int64)
    conaffinity = np.zeros(model.nbody, dtype=np.int64)
    np.bitwise_or.at(contype, model.geom_bodyid, model.geom_contype)
    np.bitwise_or.at(conaffinity, model.geom_bodyid, model.geom_conaffinity)
    model.body_contype[:] = contype
    model.body_conaffinity[:] = conaffinity


def contact_bits(model: mujoco.MjModel) -> np.ndarray:
    """Every geom's contact bits as they are now: (2, ngeom) int32, ``geom_contype`` then
    ``geom_conaffinity`` (the body masks follow from them, ``refresh_body_masks``)."""
    return np.stack((model.geom_contype, model.geom_conaffinity)).astype(np.int32)


def set_contact_bits(model: mujoco.MjModel, bits: np.ndarray) -> None:
    """Give every geom the contact bits ``bits`` (as ``contact_bits`` returns them) and
    refresh the body masks."""
    model.geom_contype[:] = bits[0]
    model.geom_conaffinity[:] = bits[1]
    refresh_body_masks(model)
