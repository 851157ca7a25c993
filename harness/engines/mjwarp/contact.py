"""The contact variant of a task model that a device job runs on.

The table verdict's replay (``harness.episode.table_verdict``, issue 33) executes a job a second
time with robot-table contact on: the same task model with other contact bits. MuJoCo Warp
fixes the geom pairs that may collide when the model is copied to the device
(``mjw.put_model``: ``nxn_geom_pair`` from ``geom_contype``/``geom_conaffinity`` and the body
masks; ``put_data`` sizes the contact rows from them too), so the bits must be those of the
job, not those the model had when the device model was made. A job therefore carries every
geom's bits as its scene's model had them when it was packed (``DeviceJob.contact``); the
device keys its device models and its lane streams by them (``contact_key``) and makes each
variant from its own copy of the model (``scene_with_contact``), so jobs of two variants never
share a device model or a lane stream, and a model changed after the call (the CPU's
``table_physical`` restores the bits on exit) does not change a device model made from it.
This module imports no Warp: planning workers pack jobs with it.
"""

from __future__ import annotations

import copy
import hashlib

import mujoco
import numpy as np

from harness.sim import Scene
from harness.sim.masks import set_contact_bits

# What the variant's data takes from the scene's (the device model's template for
# ``mjw.put_data``; every job overwrites its own start state).
_TEMPLATE_STATE = mujoco.mjtState.mjSTATE_INTEGRATION | mujoco.mjtState.mjSTATE_WARMSTART


def contact_key(bits: np.ndarray) -> str:
    """A short name of a set of contact bits (``harness.sim.masks.contact_bits``), for keys."""
    return hashlib.blake2b(
        np.ascontiguousarray(bits, dtype=np.int32).tobytes(), digest_size=8
    ).hexdigest()


def scene_with_contact(scene: Scene, bits: np.ndarray) -> Scene:
    """A shallow copy of ``scene`` on its own copy of the model with the contact bits ``bits``
    (body masks refreshed) and its own data in the scene's state."""
    model = copy.copy(scene.model)
    set_contact_bits(model, bits)
    data = mujoco.MjData(model)
    state = np.empty(mujoco.mj_stateSize(scene.model, _TEMPLATE_STATE))
    mujoco.mj_getState(scene.model, scene.data, state, _TEMPLATE_STATE)
    mujoco.mj_setState(model, data, state, _TEMPLATE_STATE)
    variant = copy.copy(scene)
    variant.model, variant.data = model, data
    return variant
