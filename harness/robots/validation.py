"""Validation of a robot.yaml against its URDF, with located errors.

Every named joint and frame must exist, home must be within the limits, timing and force limits
must not exceed the URDF's. Every problem is one located error, ``robot.yaml:line key.path:
message``.
"""

from __future__ import annotations

import math

from harness.config import ConfigError
from harness.config.yamlio import KeyPath, YamlDocument, format_key_path
from harness.robots.spec import ArmSpec, RobotFile
from harness.robots.urdf import UrdfInfo, UrdfJoint


def located_error(doc: YamlDocument, key: KeyPath, message: str) -> ConfigError:
    return ConfigError(message, file=doc.path, line=doc.line_of(key), key=format_key_path(key))


def check_interndata_block(spec: RobotFile, doc: YamlDocument) -> None:
    """The ``interndata`` block's homes name existing arms, one value per arm joint."""
    if spec.interndata is None:
        return
    for arm, home in spec.interndata.home.items():
        key: KeyPath = ("interndata", "home", arm)
        if arm not in spec.arms:
            raise located_error(doc, key, f"the robot has no {arm} arm")
        joints = len(spec.arms[arm].joints)  # pyright: ignore[reportArgumentType]
        if len(home) != joints:
            raise located_error(doc, key, f"{len(home)} values for {joints} arm joints")


def check_against_urdf(spec: RobotFile, urdf: UrdfInfo, doc: YamlDocument) -> None:
    links = set(urdf.links)

    def need_link(key: KeyPath, name: str) -> None:
        if name not in links:
            raise located_error(doc, key, f"frame {name!r} is not a link of the URDF")

    def need_joint(key: KeyPath, name: str, kinds: tuple[str, ...]) -> UrdfJoint:
        joint = urdf.joints.get(name)
        if joint is None:
            raise located_error(doc, key, f"joint {name!r} is not in the URDF")
        if joint.kind not in kinds:
            raise located_error(
                doc, key, f"joint {name!r} is {joint.kind}, expected {'/'.join(kinds)}"
            )
        return joint

    if spec.root_frame != urdf.root:
        raise located_error(doc, ("root_frame",), f"the URDF root link is {urdf.root!r}")
    used: dict[str, KeyPath] = {}
    for arm_name, arm in spec.arms.items():
        prefix: KeyPath = ("arms", arm_name)
        for field in ("base_frame", "ee_frame", "tcp_frame"):
            need_link((*prefix, field), getattr(arm, field))
        for i, body in enumerate(arm.finger_bodies):
            need_link((*prefix, "finger_bodies", i), body)
        for i, name in enumerate(arm.joints):
            key = (*prefix, "joints", i)
            if name in used:
                raise located_error(
                    doc, key, f"joint {name!r} is already used at {format_key_path(used[name])}"
                )
            used[name] = key
            joint = need_joint(key, name, ("revolute", "prismatic", "continuous"))
            _check_joint_numbers(doc, prefix, i, joint, arm)
        for i, name in enumerate(arm.finger_joints):
            joint = need_joint((*prefix, "finger_joints", i), name, ("prismatic",))
            for key, width in (("open_width", arm.open_width), ("closed_width", arm.closed_width)):
                if not joint.lower - 1e-12 <= width / 2.0 <= joint.upper + 1e-12:
                    raise located_error(
                        doc,
                        (*prefix, key),
                        f"{width} m needs {width / 2} m per finger, outside {name} limits "
                        f"[{joint.lower}, {joint.upper}]",
                    )
            if arm.gripper.speed > joint.velocity + 1e-12:
                raise located_error(
                    doc,
                    (*prefix, "gripper", "speed"),
                    f"{arm.gripper.speed} m/s exceeds the URDF velocity {joint.velocity} of {name}",
                )
    _check_variant_widths(spec, urdf, doc)
    if spec.lift is not None:
        joint = need_joint(("lift", "joint"), spec.lift.joint, ("prismatic",))
        if not joint.lower <= spec.lift.home <= joint.upper:
            raise located_error(
                doc, ("lift", "home"), f"{spec.lift.home} is outside [{joint.lower}, {joint.upper}]"
            )
        if spec.lift.velocity > joint.velocity + 1e-12:
            raise located_error(
                doc, ("lift", "velocity"), f"exceeds the URDF velocity {joint.velocity}"
            )
        if spec.lift.force_limit > joint.effort + 1e-12:
            raise located_error(
                doc, ("lift", "force_limit"), f"exceeds the URDF effort {joint.effort}"
            )


def _check_variant_widths(spec: RobotFile, urdf: UrdfInfo, doc: YamlDocument) -> None:
    """Each gripper variant's widths fit every arm's finger joint limits."""
    for name, variant in spec.gripper_variants.items():
        for key in ("open_width", "closed_width"):
            width = getattr(variant, key)
            if width is None:
                continue
            for arm in spec.arms.values():
                for finger in arm.finger_joints:
                    joint = urdf.joints.get(finger)
                    if joint is not None and not (
                        joint.lower - 1e-12 <= width / 2.0 <= joint.upper + 1e-12
                    ):
                        raise located_error(
                            doc,
                            ("gripper_variants", name, key),
                            f"{width} m needs {width / 2} m per finger, outside {finger} limits "
                            f"[{joint.lower}, {joint.upper}]",
                        )


def _check_joint_numbers(
    doc: YamlDocument, prefix: KeyPath, i: int, joint: UrdfJoint, arm: ArmSpec
) -> None:
    if (
        not (math.isfinite(joint.lower) and math.isfinite(joint.upper))
        or joint.lower >= joint.upper
    ):
        raise located_error(
            doc, (*prefix, "joints", i), f"URDF limits of {joint.name} are not a finite range"
        )
    home = arm.home[i]
    if not joint.lower <= home <= joint.upper:
        raise located_error(
            doc,
            (*prefix, "home", i),
            f"{home} is outside the {joint.name} limits [{joint.lower}, {joint.upper}]",
        )
    velocity = arm.limits.velocity[i]
    if velocity > joint.velocity + 1e-12:
        raise located_error(
            doc,
            (*prefix, "limits", "velocity", i),
            f"{velocity} exceeds the URDF velocity {joint.velocity} of {joint.name}",
        )
    force = arm.actuators.force_limit[i]
    if force > joint.effort + 1e-12:
        raise located_error(
            doc,
            (*prefix, "actuators", "force_limit", i),
            f"{force} exceeds the URDF effort {joint.effort} of {joint.name}",
        )
