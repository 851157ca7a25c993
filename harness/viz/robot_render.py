"""A picture of a robot for ``harness robots show --render FILE.png``: the robot at home drawn
offscreen (``MUJOCO_GL=egl``, or ``osmesa``) standing at its nominal place in front of a table
whose top is the world origin, with each arm's object region marked.

``placed_model`` (the robot compiled at its nominal placement) also serves the command's
description of where the arms are at home. mujoco and ``harness.robots.mujoco_spec`` (which
imports mujoco) are imported inside the functions: MuJoCo picks its GL backend when first imported.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from harness.errors import HarnessError
from harness.robots import RobotModel
from harness.viz.render import render_views, use_offscreen_gl
from harness.writes import check_target, write_through

TABLE_HEIGHT = 0.75  # m, for the render context of robots that stand on the table (fr3)


REGION_COLOURS = {"left": (0.15, 0.55, 0.95, 0.35), "right": (0.95, 0.45, 0.1, 0.35)}


@dataclass(frozen=True)
class RobotView:
    """The camera of a robot picture (``harness robots show --distance/--azimuth/--elevation``):
    distance from the look-at point in m (None: 1.9, or 2.1 for a robot standing on the floor,
    which is taller in the frame), azimuth and elevation in degrees (MuJoCo's ``mjvCamera``)."""

    distance: float | None = None
    azimuth: float = -150.0  # from the front right of the robot
    elevation: float = -20.0


def placed_model(
    robot: RobotModel, with_context: bool, size: tuple[int, int] = (960, 720)
) -> tuple[Any, Any]:
    """Compile the robot at its nominal placement; with a floor, table and lights if asked."""
    import mujoco

    from harness.robots.mujoco_spec import build_robot_spec, configure_contact_options

    position, yaw = robot.nominal_placement()
    scene = mujoco.MjSpec()
    configure_contact_options(scene)
    frame = scene.worldbody.add_frame(
        pos=position, quat=[np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]
    )
    scene.attach(build_robot_spec(robot), frame=frame, prefix="robot/")
    if with_context:
        floor_z = position[2] if position[2] < -0.1 else -TABLE_HEIGHT
        _add_context(scene, robot, floor_z, size)
    return scene.compile(), scene


def _add_context(scene: Any, robot: RobotModel, floor_z: float, size: tuple[int, int]) -> None:
    import mujoco

    scene.visual.global_.offwidth, scene.visual.global_.offheight = size
    scene.visual.headlight.ambient = [0.35, 0.35, 0.35]
    scene.visual.headlight.diffuse = [0.45, 0.45, 0.45]
    scene.add_texture(
        name="sky",
        type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
        rgb1=[0.72, 0.8, 0.9],
        rgb2=[0.98, 0.98, 0.98],
        width=256,
        height=256,
    )
    scene.add_texture(
        name="floor_grid",
        type=mujoco.mjtTexture.mjTEXTURE_2D,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
        rgb1=[0.82, 0.82, 0.8],
        rgb2=[0.72, 0.72, 0.7],
        width=256,
        height=256,
    )
    material = scene.add_material(name="floor_grid", texrepeat=[8, 8], reflectance=0.05)
    material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "floor_grid"
    world = scene.worldbody
    world.add_geom(
        type=mujoco.mjtGeom.mjGEOM_PLANE,
        size=[4, 4, 0.1],
        pos=[0, 0, floor_z],
        material="floor_grid",
    )
    world.add_light(pos=[1.5, 1.0, 3.0], dir=[-0.5, -0.4, -1.0], diffuse=[0.6, 0.6, 0.6])
    world.add_light(pos=[-1.5, 2.0, 2.5], dir=[0.5, -0.6, -1.0], diffuse=[0.35, 0.35, 0.35])
    # Table: top at z 0 (the world origin), long enough in -y to carry a table-mounted robot.
    y_min = -0.6 if robot.placement.pos_range[0][2] >= -0.1 else -0.4
    y_max = 0.4
    thickness = 0.04
    top = dict(contype=0, conaffinity=0, rgba=[0.62, 0.48, 0.34, 1.0])
    world.add_geom(
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[0.6, (y_max - y_min) / 2, thickness / 2],
        pos=[0, (y_max + y_min) / 2, -thickness / 2],
        **top,
    )
    leg = (-floor_z - thickness) / 2
    for x in (-0.56, 0.56):
        for y in (y_min + 0.04, y_max - 0.04):
            world.add_geom(
                type=mujoco.mjtGeom.mjGEOM_BOX,
                size=[0.025, 0.025, leg],
                pos=[x, y, floor_z + leg],
                **top,
            )
    for arm in robot.arms.values():
        lo, hi = (np.asarray(v, dtype=float) for v in arm.object_region.pos_range)
        world.add_geom(
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[(hi[0] - lo[0]) / 2, (hi[1] - lo[1]) / 2, 0.0008],
            pos=[(hi[0] + lo[0]) / 2, (hi[1] + lo[1]) / 2, 0.0009],
            contype=0,
            conaffinity=0,
            rgba=list(REGION_COLOURS[arm.name]),
        )


def render_robot(
    robot: RobotModel,
    path: str | Path,
    size: tuple[int, int] = (960, 720),
    view: RobotView | None = None,
) -> Path:
    """Render the robot at home at its nominal placement to a PNG (offscreen), seen by
    ``view`` (default ``RobotView()``)."""
    view = view or RobotView()
    use_offscreen_gl()
    import mujoco
    from PIL import Image

    from harness.robots.mujoco_spec import robot_addresses, set_configuration

    model, _ = placed_model(robot, with_context=True, size=size)
    data = mujoco.MjData(model)
    addresses = robot_addresses(model, robot, prefix="robot/")
    set_configuration(model, data, addresses, robot.home_configuration())
    mujoco.mj_forward(model, data)
    camera = mujoco.MjvCamera()
    root = data.xpos[addresses.root_body]
    floor_robot = root[2] < -0.1
    # Look between the robot and the table centre, from the front-right of the robot.
    camera.lookat[:] = [0.0, root[1] * 0.6, 0.0 if floor_robot else 0.25]
    default_distance = 2.1 if floor_robot else 1.9
    camera.distance = view.distance if view.distance is not None else default_distance
    camera.azimuth = view.azimuth
    camera.elevation = view.elevation
    width, height = size
    path = Path(path)
    check_target(path)
    try:
        (image,) = render_views(model, data, camera, width, height)
        write_through(path, Image.fromarray(image).save)
    except Exception as exc:  # no GL platform: one clear line, not a traceback
        raise HarnessError(
            f"offscreen rendering failed ({exc}); set MUJOCO_GL=egl or MUJOCO_GL=osmesa"
        ) from exc
    return path
