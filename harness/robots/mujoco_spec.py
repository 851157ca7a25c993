"""MuJoCo side of a robot: an ``MjSpec`` ready to attach into a scene, and address helpers.

``build_robot_spec(robot)`` loads the robot's URDF through ``MjSpec`` (the URDF carries its own
``<mujoco><compiler discardvisual="false" fusestatic="false" balanceinertia="true"/>`` so every
URDF link, including the massless arm-base / TCP frames, stays a body) and adds, following the
MuJoCo Menagerie gripper recipe (../shared/reference/robots.md sections 7-8):

- position servos named after their joint on every arm joint and on the lift, with kp / kv /
  force limits from robot.yaml, ``ctrlrange`` = the joint range; joint damping, armature and
  frictionloss from robot.yaml; ``gravcomp = 1`` on every robot body (ideal gravity compensation,
  so the servos only track);
- per gripper: the two finger slides coupled by a joint equality (finger 2 = finger 1) and ONE
  force-limited position servo ``<arm>_gripper`` on finger 1. **Its ctrl is the per-finger
  opening in m** (0 = closed, ``open_width / 2`` = open). Closing (ctrl 0) on an object of width
  w, the servo pushes ``kp * w / 2``, shared by the two pads: ``kp * w / 4`` normal force each,
  capped at the gripper's grasp force ``force_limit`` (the servo's force range is twice it).
  The finger travel is the selected gripper variant's (``harness.robots.gripper``);
- the fingers' collision boxes are pads (the one named ``<finger>_pad`` is the fingertip pad
  whose gap ``pad_gap`` reports): the gripper's ``pad_friction``, condim 4 (torsional friction
  against pivoting) and a stiffer solref; finger-finger contacts are excluded (the pads meet when
  closed), and so are contacts across each joint (links that overlap by construction; MuJoCo's
  own parent-child filter does not apply when the parent is welded to the world);
- every other pair of links that ``collisions.json`` leaves out is excluded too, so the
  physics, the planner's checks and the execution check count one list of self-collision
  pairs (``RobotModel.self_collision_pairs``).

Geoms: URDF visuals are group 1 (no contact), collision geoms group 3 (hidden by default),
named ``<link>_col<i>`` / ``<finger>_pad``.

Scene-level options that make grasps hold (they belong to the scene, because after
``scene.attach(spec, frame=..., prefix="robot/")`` the parent's options apply): timestep 0.002,
``integrator = implicitfast``, **``cone = elliptic`` with ``impratio = 10``** (pyramidal cones
or impratio 1 let a held box creep by mm/s; elliptic + 10 brings it to ~0.1 mm/s). Tasks add
MuJoCo's noslip pass (``PhysicsConfig.noslip_iterations``, default 10: no creep inside the
friction limit, docs/robots.md); ``configure_contact_options`` leaves it off (the soft model the
numbers below measure). ``configure_contact_options(spec)`` sets them;
the robot spec itself keeps MuJoCo's defaults so attaching it raises no option conflicts (call
it on the robot spec only to simulate the robot on its own). Measured with these options: a
4 cm, 0.1 kg cube held at 5 N per pad creeps 0.12-0.17 mm/s (tests/test_robot_mujoco.py).

Position servos damp absolute joint velocity (``-kv * qdot``), so a moving target lags by
``(kv / kp) * qdot``; feed ``ctrl = q_ref + (kv / kp) * qdot_ref`` to track a trajectory.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from harness.robots.model import RobotModel
from harness.robots.spec import ArmSpec

PAD_ROLL = 0.0001  # rolling friction of the pads (m); the torsional: gripper.pad_torsion
PAD_CONDIM = 4
PAD_SOLREF = (0.01, 1.0)
FINGER_EQUALITY_SOLREF = (0.005, 1.0)
FINGER_EQUALITY_SOLIMP = (0.95, 0.99, 0.001, 0.5, 2.0)
VISUAL_GROUP = 1
COLLISION_GROUP = 3


def configure_contact_options(spec: mujoco.MjSpec) -> None:
    """The options grasps need: 2 ms implicitfast steps, elliptic cones, impratio 10."""
    spec.option.timestep = 0.002
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = 10.0


def build_robot_spec(robot: RobotModel) -> mujoco.MjSpec:
    """The robot as an ``MjSpec``: root body ``robot.root_frame``, actuators, gripper coupling."""
    spec = mujoco.MjSpec.from_file(str(robot.urdf_path))
    spec.modelname = robot.name
    _name_and_group_geoms(spec)
    _exclude_adjacent_contacts(spec, robot)
    _exclude_unlisted_pairs(spec, robot)
    for body in spec.bodies:
        if body.name != "world":
            body.gravcomp = 1.0
    for joint_name in robot.actuated_joints:
        dyn = robot.dynamics(joint_name)
        joint = spec.joint(joint_name)
        joint.damping = [dyn.damping, 0.0, 0.0]  # MuJoCo 4: polynomial damping coefficients
        joint.armature = dyn.armature
        joint.frictionloss = dyn.frictionloss
        _position_servo(spec, joint_name, joint_name, dyn.kp, dyn.kv, (dyn.lower, dyn.upper))
        _force_limit(spec.actuator(joint_name), dyn.force_limit)
    for arm in robot.arms.values():
        _add_gripper(spec, arm)
    return spec


def _name_and_group_geoms(spec: mujoco.MjSpec) -> None:
    for index, geom in enumerate(spec.geoms):
        body = geom.parent.name
        if geom.contype == 0 and geom.conaffinity == 0:  # URDF visual
            geom.group = VISUAL_GROUP
            if not geom.name:
                geom.name = f"{body}_vis{index}"
            continue
        geom.group = COLLISION_GROUP
        if not geom.name:
            geom.name = f"{body}_col{index}"


def _exclude_adjacent_contacts(spec: mujoco.MjSpec, robot: RobotModel) -> None:
    """Exclude contacts across each moving joint (links that touch by construction).

    MuJoCo already skips parent-child pairs, but not when the parent is welded to the world
    (the robot's static root group), and not across massless fixed frames between joints.
    """
    joints = robot.urdf.joints
    parent_joint = {j.child: j for j in joints.values()}

    def rigid_group(link: str) -> list[str]:
        """Links rigidly attached to ``link`` through fixed joints (up and down the tree)."""
        top = link
        while top in parent_joint and parent_joint[top].kind == "fixed":
            top = parent_joint[top].parent
        group, stack = [], [top]
        while stack:
            current = stack.pop()
            group.append(current)
            stack += [j.child for j in joints.values() if j.parent == current and j.kind == "fixed"]
        return group

    has_geoms = {geom.parent.name for geom in spec.geoms if geom.contype or geom.conaffinity}
    for joint in joints.values():
        if joint.kind == "fixed":
            continue
        for a in rigid_group(joint.parent):
            for b in rigid_group(joint.child):
                if a in has_geoms and b in has_geoms:
                    spec.add_exclude(bodyname1=a, bodyname2=b)


def _exclude_unlisted_pairs(spec: mujoco.MjSpec, robot: RobotModel) -> None:
    """Exclude every contact between two links that ``collisions.json`` does not list.

    One list of self-collision pairs for the physics, the planner and the execution check: the
    generated file already leaves out adjacent links, the two fingers of a gripper, pairs
    touching at home and a robot's declared artefact pairs (FR3 link1-link3, whose capsules
    overlap inside link2's J2 housing, robots/fr3/build.py); without this exclusion MuJoCo kept
    the artefact pair, and the planner failed an FR3 cube approach for it (issue 55). Pairs
    across one rigid group or one joint are excluded already (``_exclude_adjacent_contacts``
    and MuJoCo's own filters); excluding them again is harmless but skipped."""
    listed = robot.self_collision_pairs()
    joints = robot.urdf.joints
    parent_joint = {j.child: j for j in joints.values()}

    def root_of(link: str) -> str:
        while link in parent_joint and parent_joint[link].kind == "fixed":
            link = parent_joint[link].parent
        return link

    has_geoms = sorted(
        {geom.parent.name for geom in spec.geoms if geom.contype or geom.conaffinity}
    )
    for index, a in enumerate(has_geoms):
        for b in has_geoms[index + 1 :]:
            ra, rb = root_of(a), root_of(b)
            if ra == rb or frozenset((a, b)) in listed:
                continue
            adjacent = any(
                {root_of(j.parent), j.child} == {ra, rb}
                for j in (parent_joint.get(ra), parent_joint.get(rb))
                if j is not None and j.kind != "fixed"
            )
            if not adjacent:
                spec.add_exclude(bodyname1=a, bodyname2=b)


def _position_servo(
    spec: mujoco.MjSpec,
    name: str,
    joint: str,
    kp: float,
    kv: float,
    ctrl_range: tuple[float, float],
) -> mujoco.MjsActuator:
    actuator = spec.add_actuator(name=name, target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
    actuator.set_to_position(kp=kp, kv=kv)
    actuator.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
    actuator.ctrlrange = list(ctrl_range)
    return actuator


FINGER_LIMIT_SOLREF = (0.002, 1.0)


def _force_limit(actuator: mujoco.MjsActuator, limit: float) -> None:
    actuator.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
    actuator.forcerange = [-limit, limit]


def _add_gripper(spec: mujoco.MjSpec, arm: ArmSpec) -> None:
    driven, follower = arm.finger_joints
    for name in arm.finger_joints:
        joint = spec.joint(name)
        joint.damping = [arm.gripper.damping, 0.0, 0.0]
        joint.armature = arm.gripper.armature
        joint.frictionloss = arm.gripper.frictionloss
        # MuJoCo's URDF import turns the URDF effort into a joint actuator force range, which
        # clamps the servo silently (the Piper URDF's 10 N capped a 20 N servo at a 5 N grasp);
        # the gripper's force limit below is the one limit on the grip.
        joint.actfrclimited = mujoco.mjtLimited.mjLIMITED_FALSE
        # The selected variant's travel (the URDF allows the widest variant's).
        joint.range = [arm.finger_closed_position, arm.finger_open_position]
        # Stiff travel limits: with the default soft limit a large object pried the FR3 fingers
        # open to 14.6 cm against a 4 cm stroke; 2 ms limit stiffness holds them near it.
        joint.solref_limit = list(FINGER_LIMIT_SOLREF)
    spec.add_equality(
        name=f"{arm.name}_finger_coupling",
        type=mujoco.mjtEq.mjEQ_JOINT,
        objtype=mujoco.mjtObj.mjOBJ_JOINT,
        name1=follower,
        name2=driven,
        data=[0.0, 1.0, 0.0, 0.0, 0.0] + [0.0] * 7,  # polycoef: follower = driven
        solref=list(FINGER_EQUALITY_SOLREF),
        solimp=list(FINGER_EQUALITY_SOLIMP),
    )
    actuator = _position_servo(
        spec,
        gripper_actuator_name(arm.name),
        driven,
        arm.gripper.kp,
        arm.gripper.kv,
        # down to the squeeze target: a force-controlled grasp drives past the closed width
        (arm.finger_squeeze_position, arm.finger_open_position),
    )
    # Finger 1's servo squeezes against finger 2 held by the coupling: each pad presses with
    # half the servo force, so the grasp force limit is half the servo's force range.
    _force_limit(actuator, 2.0 * arm.gripper.force_limit)
    spec.add_exclude(bodyname1=arm.finger_bodies[0], bodyname2=arm.finger_bodies[1])
    _pad_contacts(spec, arm)


def _pad_contacts(spec: mujoco.MjSpec, arm: ArmSpec) -> None:
    """Every collision geom of the fingers is a pad: the arm's pad friction, condim 4
    (torsional friction against pivoting) and a stiffer solref."""
    for geom in spec.geoms:
        if geom.parent.name in arm.finger_bodies and geom.group == COLLISION_GROUP:
            geom.friction = [arm.gripper.pad_friction, arm.gripper.pad_torsion, PAD_ROLL]
            geom.condim = PAD_CONDIM
            geom.solref = list(PAD_SOLREF)


def finger_pad_geoms(spec: mujoco.MjSpec, robot: RobotModel) -> list[str]:
    """Names of every finger collision geom (the pads) of every arm in ``spec``."""
    fingers = {body for arm in robot.arms.values() for body in arm.finger_bodies}
    return [
        geom.name
        for geom in spec.geoms
        if geom.parent.name in fingers and geom.group == COLLISION_GROUP and geom.name
    ]


def gripper_actuator_name(arm: str) -> str:
    return f"{arm}_gripper"


# --------------------------------------------------------------------------------------------
# Addresses in a compiled model


@dataclass(frozen=True)
class ArmAddresses:
    """Where one arm lives in a compiled ``MjModel`` (ids and qpos / dof / ctrl indices)."""

    name: str
    qpos: np.ndarray  # arm joints, in robot.yaml order
    dof: np.ndarray
    ctrl: np.ndarray  # their actuators
    gripper_ctrl: int
    finger_qpos: tuple[int, int]
    finger_bodies: tuple[int, int]
    pad_geoms: tuple[int, int]
    finger_joint_ids: tuple[int, int]
    base_body: int
    ee_body: int
    tcp_body: int


@dataclass(frozen=True)
class RobotAddresses:
    """Addresses of a robot inside a (possibly larger) compiled model."""

    prefix: str
    arms: dict[str, ArmAddresses]
    root_body: int
    lift_qpos: int | None
    lift_ctrl: int | None
    joint_qpos: dict[str, int]  # every movable robot joint (unprefixed name) -> qpos index
    actuator_ids: dict[str, int]  # actuator (unprefixed name) -> ctrl index
    body_ids: dict[str, int]  # every robot body (unprefixed link name) -> body id
    geom_ids: np.ndarray  # every robot geom


def robot_addresses(model: mujoco.MjModel, robot: RobotModel, prefix: str = "") -> RobotAddresses:
    """Resolve a robot's joints, actuators, bodies and pads in ``model`` (names get ``prefix``)."""

    def jid(name: str) -> int:
        return model.joint(prefix + name).id

    def aid(name: str) -> int:
        return model.actuator(prefix + name).id

    def bid(name: str) -> int:
        return model.body(prefix + name).id

    arms = {}
    for arm in robot.arms.values():
        ids = [jid(j) for j in arm.joints]
        fingers = tuple(jid(j) for j in arm.finger_joints)
        arms[arm.name] = ArmAddresses(
            name=arm.name,
            qpos=np.array([model.jnt_qposadr[i] for i in ids]),
            dof=np.array([model.jnt_dofadr[i] for i in ids]),
            ctrl=np.array([aid(j) for j in arm.joints]),
            gripper_ctrl=aid(gripper_actuator_name(arm.name)),
            finger_qpos=(int(model.jnt_qposadr[fingers[0]]), int(model.jnt_qposadr[fingers[1]])),
            finger_bodies=(bid(arm.finger_bodies[0]), bid(arm.finger_bodies[1])),
            pad_geoms=(
                model.geom(f"{prefix}{arm.finger_bodies[0]}_pad").id,
                model.geom(f"{prefix}{arm.finger_bodies[1]}_pad").id,
            ),
            finger_joint_ids=(int(fingers[0]), int(fingers[1])),
            base_body=bid(arm.base_frame),
            ee_body=bid(arm.ee_frame),
            tcp_body=bid(arm.tcp_frame),
        )
    joint_qpos = {j: int(model.jnt_qposadr[jid(j)]) for j in robot.movable_joints}
    actuators = {name: aid(name) for name in robot.actuated_joints}
    actuators.update({gripper_actuator_name(a): arms[a].gripper_ctrl for a in arms})
    body_ids = {link: bid(link) for link in robot.frames}
    robot_bodies = np.array(list(body_ids.values()))
    geom_ids = np.flatnonzero(np.isin(model.geom_bodyid, robot_bodies))
    return RobotAddresses(
        prefix=prefix,
        arms=arms,
        root_body=bid(robot.root_frame),
        lift_qpos=joint_qpos[robot.lift_joint] if robot.lift_joint else None,
        lift_ctrl=actuators[robot.lift_joint] if robot.lift_joint else None,
        joint_qpos=joint_qpos,
        actuator_ids=actuators,
        body_ids=body_ids,
        geom_ids=geom_ids,
    )


def set_configuration(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    addresses: RobotAddresses,
    q: dict[str, float],
) -> None:
    """Write joint values into qpos and the matching servo targets into ctrl (no forward call).

    Finger values set both fingers' qpos; the gripper ctrl follows the driven finger.
    """
    for joint, value in q.items():
        data.qpos[addresses.joint_qpos[joint]] = value
        if joint in addresses.actuator_ids:
            data.ctrl[addresses.actuator_ids[joint]] = value
    for arm in addresses.arms.values():
        data.ctrl[arm.gripper_ctrl] = data.qpos[arm.finger_qpos[0]]
    data.qvel[:] = 0.0
    del model


def pad_gap(model: mujoco.MjModel, data: mujoco.MjData, arm: ArmAddresses) -> float:
    """Distance between the two pad faces along the closing axis (m); needs kinematics done."""
    axis = data.xaxis[arm.finger_joint_ids[0]].copy()  # finger 1 opening direction, world
    axis /= np.linalg.norm(axis)
    half_depths = []
    for geom in arm.pad_geoms:
        R = data.geom_xmat[geom].reshape(3, 3)
        half_depths.append(float(np.abs(R.T @ axis) @ model.geom_size[geom]))
    c1, c2 = (data.geom_xpos[g] for g in arm.pad_geoms)
    return float((c1 - c2) @ axis - half_depths[0] - half_depths[1])
