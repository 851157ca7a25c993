"""Offscreen MuJoCo rendering, shared by the CLI's pictures (``harness robots show --render`` and
``harness objects show --render``): a compiled model seen from one camera, one image per set of
visible geom groups.

MuJoCo picks its GL backend when it is first imported, so ``use_offscreen_gl`` defaults
``MUJOCO_GL`` to ``egl`` (``osmesa`` works too) and mujoco is imported inside the functions that
render, after it, never at module import.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import numpy as np


def use_offscreen_gl() -> None:
    """Default ``MUJOCO_GL`` to ``egl``; call before mujoco is first imported."""
    os.environ.setdefault("MUJOCO_GL", "egl")


def render_views(
    model: Any,
    data: Any,
    camera: Any,
    width: int,
    height: int,
    geom_groups: Sequence[Sequence[int]] | None = None,
) -> list[np.ndarray]:
    """RGB images of ``data`` from ``camera``, ``height`` x ``width`` pixels.

    With ``geom_groups`` one image per entry, showing only the geoms of those groups; without,
    one image with MuJoCo's default visibility.
    """
    import mujoco

    images: list[np.ndarray] = []
    with mujoco.Renderer(model, height, width) as renderer:
        if geom_groups is None:
            renderer.update_scene(data, camera)
            images.append(renderer.render())
            return images
        for groups in geom_groups:
            option = mujoco.MjvOption()
            option.geomgroup[:] = 0
            for g in groups:
                option.geomgroup[g] = 1
            renderer.update_scene(data, camera, option)
            images.append(renderer.render().copy())
    return images
