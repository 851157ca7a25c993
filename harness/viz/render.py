"""Offscreen MuJoCo rendering, shared by the CLI's pictures (``harness robots show --render`` and
``harness objects show --render``): a compiled model seen from one camera, one image per set of
visible geom groups.

MuJoCo picks its GL backend when it is first imported, so ``use_offscreen_gl`` defaults
``MUJOCO_GL`` to ``egl`` (``osmesa`` works too) and mujoco is imported inside the functions that
render, after it, never at module import.
"""

from __future__ import annotations

import functools
import os
import subprocess
import sys
from collections.abc import Sequence
from typing import Any

import numpy as np

# A GL context is made in well under a second where one can be made (the child's mujoco
# import included); a driver that hangs is given up on. Chosen, no public source.
GL_PROBE_TIMEOUT_S = 60.0
# What a video does, at 16 x 16 pixels: a GLFW context "made" without a display still passes
# GLContext(); only the renderer's mjr_makeContext tells.
_PROBE = (
    "import mujoco\n"
    'm = mujoco.MjModel.from_xml_string(\'<mujoco><worldbody><geom size="1"/></worldbody>'
    "</mujoco>')\n"
    "with mujoco.Renderer(m, 16, 16) as r:\n"
    "    r.update_scene(mujoco.MjData(m))\n"
    "    r.render()\n"
)


def use_offscreen_gl() -> None:
    """Default ``MUJOCO_GL`` to ``egl``; call before mujoco is first imported."""
    os.environ.setdefault("MUJOCO_GL", "egl")


@functools.lru_cache(maxsize=1)
def offscreen_gl_problem() -> str | None:
    """None if MuJoCo can make an offscreen GL context here, else why not (one line).

    Call before this process imports mujoco (it defaults ``MUJOCO_GL`` to ``egl``). The
    context is made in a child process: with ``MUJOCO_GL`` unset and no display MuJoCo fell
    back to GLFW and the process aborted natively in libc++ ("recursive initialization"),
    after a sweep's rows but before its report. A child that aborts takes only itself down.
    """
    use_offscreen_gl()
    backend = os.environ["MUJOCO_GL"]
    mujoco = sys.modules.get("mujoco")
    context = getattr(mujoco, "GLContext", None)
    if context is not None and context.__module__.rsplit(".", 1)[-1] not in ("egl", "osmesa"):
        return f"mujoco was imported with the {context.__module__} backend (set MUJOCO_GL=egl)"
    try:
        probe = subprocess.run(
            [sys.executable, "-c", _PROBE],
            capture_output=True,
            text=True,
            timeout=GL_PROBE_TIMEOUT_S,
            check=False,
        )
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"MUJOCO_GL={backend}: the GL probe failed ({exc})"
    if probe.returncode == 0:
        return None
    lines = [line.strip() for line in probe.stderr.splitlines() if line.strip()]
    reason = lines[-1][:200] if lines else f"exit status {probe.returncode}"
    return f"MUJOCO_GL={backend} cannot make a GL context: {reason}"


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
