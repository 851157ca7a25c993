"""``harness robots list`` and ``harness robots show NAME [--render FILE.png]``.

``show`` prints the arms (joints with limits, timing limits, frames, fingers, widths, home),
the grasp convention, the lift and the placement, then where each arm sits in the world at the
nominal placement and where its TCP and approach axis point at home. ``--render`` draws the
robot at home offscreen (``MUJOCO_GL=egl``, or ``osmesa``) standing at its nominal place in
front of a table whose top is the world origin, with each arm's object region marked.
"""

from __future__ import annotations

import argparse
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from harness.errors import HarnessError
from harness.robots import RobotModel, available_robots

TABLE_HEIGHT = 0.75  # m, for the render context of robots that stand on the table (fr3)
REGION_COLOURS = {"left": (0.15, 0.55, 0.95, 0.35), "right": (0.95, 0.45, 0.1, 0.35)}


def list_robots(args: argparse.Namespace) -> int:
    del args
    for name in available_robots():
        robot = RobotModel.load(name)
        arms = ", ".join(
            f"{arm.name} ({len(arm.joints)} joints, {arm.open_width * 1e3:.0f} mm gripper)"
            for arm in robot.arms.values()
        )
        lift = f", lift {robot.lift_joint}" if robot.lift_joint else ""
        print(f"{name:12s} arms: {arms}{lift}  [{robot.yaml_path}]")
    return 0


# --------------------------------------------------------------------------------------------
# Poses at home (MuJoCo forward kinematics at the nominal placement)


@dataclass(frozen=True)
class ArmAtHome:
    """Where one arm is at the nominal placement with the robot at home (world frame)."""

    name: str
    base_position: np.ndarray
    tcp_position: np.ndarray
    approach_world: np.ndarray  # approach axis in the world frame
    approach_in_base: np.ndarray  # approach axis in the arm base frame
    region_centre: np.ndarray

    @property
    def base_to_region(self) -> float:
        """Horizontal distance from the arm base to its object-region centre (m)."""
        return float(np.linalg.norm((self.region_centre - self.base_position)[:2]))


def arms_at_home(robot: RobotModel) -> list[ArmAtHome]:
    import mujoco

    from harness.robots.mujoco_spec import robot_addresses, set_configuration

    model, _ = _placed_model(robot, with_context=False)
    data = mujoco.MjData(model)
    addresses = robot_addresses(model, robot, prefix="robot/")
    set_configuration(model, data, addresses, robot.home_configuration())
    mujoco.mj_forward(model, data)
    axis = "xyz".index(robot.convention.approach_axis)
    out = []
    for arm in robot.arms.values():
        a = addresses.arms[arm.name]
        R_ee = data.xmat[a.ee_body].reshape(3, 3)
        R_base = data.xmat[a.base_body].reshape(3, 3)
        lo, hi = (np.asarray(v, dtype=float) for v in arm.object_region.pos_range)
        out.append(
            ArmAtHome(
                name=arm.name,
                base_position=data.xpos[a.base_body].copy(),
                tcp_position=data.xpos[a.tcp_body].copy(),
                approach_world=R_ee[:, axis].copy(),
                approach_in_base=R_base.T @ R_ee[:, axis],
                region_centre=(lo + hi) / 2.0,
            )
        )
    return out


def _placed_model(robot: RobotModel, with_context: bool, size: tuple[int, int] = (960, 720)):
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


def _add_context(scene, robot: RobotModel, floor_z: float, size: tuple[int, int]) -> None:
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


def render(robot: RobotModel, path: str | Path, size: tuple[int, int] = (960, 720)) -> Path:
    """Render the robot at home at its nominal placement to a PNG (offscreen)."""
    os.environ.setdefault("MUJOCO_GL", "egl")
    import mujoco
    from PIL import Image

    from harness.robots.mujoco_spec import robot_addresses, set_configuration

    model, _ = _placed_model(robot, with_context=True, size=size)
    data = mujoco.MjData(model)
    addresses = robot_addresses(model, robot, prefix="robot/")
    set_configuration(model, data, addresses, robot.home_configuration())
    mujoco.mj_forward(model, data)
    camera = mujoco.MjvCamera()
    root = data.xpos[addresses.root_body]
    floor_robot = root[2] < -0.1
    # Look between the robot and the table centre, from the front-right of the robot.
    camera.lookat[:] = [0.0, root[1] * 0.6, 0.0 if floor_robot else 0.25]
    camera.distance = float(os.environ.get("HARNESS_RENDER_DISTANCE", 2.1 if floor_robot else 1.9))
    camera.azimuth = float(os.environ.get("HARNESS_RENDER_AZIMUTH", -150.0))
    camera.elevation = float(os.environ.get("HARNESS_RENDER_ELEVATION", -20.0))
    width, height = size
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        with mujoco.Renderer(model, height, width) as renderer:
            renderer.update_scene(data, camera)
            Image.fromarray(renderer.render()).save(path)
    except Exception as exc:  # no GL platform: one clear line, not a traceback
        raise HarnessError(
            f"offscreen rendering failed ({exc}); set MUJOCO_GL=egl or MUJOCO_GL=osmesa"
        ) from exc
    return path


# --------------------------------------------------------------------------------------------
# show


def _vec(values: object, digits: int = 3) -> str:
    return "[" + ", ".join(f"{v:.{digits}f}" for v in np.asarray(values, dtype=float).ravel()) + "]"


def describe(robot: RobotModel) -> list[str]:
    c = robot.convention
    lines = [
        f"robot {robot.name}: {robot.description}",
        f"  files: {robot.yaml_path}, {robot.urdf_path.name}, {robot.collisions_path.name}",
        f"  root frame {robot.root_frame}; placement pos_range {robot.placement.pos_range}, "
        f"yaw {robot.placement.yaw_range} deg",
        f"  convention: R_ee_graspnet {c.R_ee_graspnet.astype(int).tolist()}, ee/approach axis "
        f"{c.ee_axis}, facing axis {c.facing_axis}, tcp_offset {c.tcp_offset}, gripper width "
        f"{c.gripper_min_width}-{c.gripper_max_width} m",
    ]
    if robot.lift is not None:
        lo, hi = robot.joint_limits(robot.lift.joint)
        lines.append(
            f"  lift {robot.lift.joint}: range {lo}-{hi} m, home {robot.lift.home}, "
            f"{robot.lift.velocity} m/s, {robot.lift.acceleration} m/s^2, kp {robot.lift.kp}"
        )
    for arm in robot.arms.values():
        lines += [
            f"  arm {arm.name}: base {arm.base_frame}, ee {arm.ee_frame}, tcp {arm.tcp_frame}",
            f"    fingers {list(arm.finger_joints)} (links {list(arm.finger_bodies)}), width "
            f"{arm.closed_width}-{arm.open_width} m; servo kp {arm.gripper.kp} N/m, force "
            f"{arm.gripper.force_limit} N, speed {arm.gripper.speed} m/s",
            f"    object region {arm.object_region.pos_range}, yaw {arm.object_region.yaw_range}",
            "    joint            lower    upper     home    noise  vel   acc    jerk    kp",
        ]
        for i, joint in enumerate(arm.joints):
            d = robot.dynamics(joint)
            lines.append(
                f"    {joint:14s} {d.lower:8.4f} {d.upper:8.4f} {arm.home[i]:8.4f} "
                f"{arm.home_noise_std[i]:8.4f} {d.velocity:5.2f} {d.acceleration:5.1f} "
                f"{d.jerk:7.0f} {d.kp:6.0f}"
            )
    for pose in arms_at_home(robot):
        lines.append(
            f"  at home, nominal placement: {pose.name} arm base at {_vec(pose.base_position)}, "
            f"TCP at {_vec(pose.tcp_position)}, approach axis (world) {_vec(pose.approach_world)}"
            f" = {_vec(pose.approach_in_base)} in the arm base; object region centre "
            f"{pose.base_to_region:.3f} m from the arm base (horizontal)"
        )
    return lines


def show(args: argparse.Namespace) -> int:
    if getattr(args, "render", None):
        # MuJoCo picks its GL backend when first imported, which describe() does.
        os.environ.setdefault("MUJOCO_GL", "egl")
    robot = RobotModel.load(args.name)
    for line in describe(robot):
        print(line)
    if getattr(args, "render", None):
        path = render(robot, args.render)
        print(f"rendered {path}")
    return 0
