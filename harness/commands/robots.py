"""``harness robots list`` and ``harness robots show NAME [--render FILE.png]``.

``show`` prints the arms (joints with limits, timing limits, frames, fingers, widths, home),
the grasp convention, the lift and the placement, then where each arm sits in the world at the
nominal placement and where its TCP and approach axis point at home. ``--render`` draws the
robot at home offscreen (``MUJOCO_GL=egl``, or ``osmesa``) standing at its nominal place in
front of a table whose top is the world origin, with each arm's object region marked (drawn by
``harness.viz.robot_render``).
"""

from __future__ import annotations

import argparse
import os
from dataclasses import dataclass

import numpy as np

from harness.commands.console import say
from harness.robots import RobotModel, available_robots
from harness.viz.formats import IMAGE_SUFFIXES, check_suffix
from harness.viz.robot_render import RobotView, placed_model, render_robot


def list_robots(args: argparse.Namespace) -> int:
    del args
    for name in available_robots():
        robot = RobotModel.load(name)
        arms = ", ".join(
            f"{arm.name} ({len(arm.joints)} joints, {arm.open_width * 1e3:.0f} mm gripper)"
            for arm in robot.arms.values()
        )
        lift = f", lift {robot.lift_joint}" if robot.lift_joint else ""
        say(f"{name:12s} arms: {arms}{lift}  [{robot.yaml_path}]")
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

    model, _ = placed_model(robot, with_context=False)
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
        check_suffix(args.render, IMAGE_SUFFIXES, "--render")
        # MuJoCo picks its GL backend when first imported, which describe() does.
        os.environ.setdefault("MUJOCO_GL", "egl")
    robot = RobotModel.load(args.name)
    for line in describe(robot):
        say(line)
    if getattr(args, "render", None):
        view = RobotView(args.distance, args.azimuth, args.elevation)
        path = render_robot(robot, args.render, view=view)
        say(f"rendered {path}")
    return 0
