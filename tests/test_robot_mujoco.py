"""MuJoCo robots: FK agrees with placo, grippers open / close to their widths and hold a cube."""

from __future__ import annotations

import mujoco
import numpy as np
import placo
import pytest
from helpers import ROBOT_ARMS, ROBOTS

from harness.robots import RobotModel
from harness.robots.mujoco_spec import (
    ArmAddresses,
    build_robot_spec,
    configure_contact_options,
    pad_gap,
    robot_addresses,
    set_configuration,
)

ARMS = ROBOT_ARMS

CUBE_SIZE = 0.04
CUBE_MASS = 0.1


@pytest.fixture(scope="module", params=ROBOTS)
def robot(request: pytest.FixtureRequest) -> RobotModel:
    return RobotModel.load(request.param)


def test_fk_matches_placo_on_every_frame(robot: RobotModel) -> None:
    """200 random in-limit configurations (both arms, fingers, lift): every link frame agrees."""
    model = build_robot_spec(robot).compile()
    data = mujoco.MjData(model)
    addresses = robot_addresses(model, robot)
    wrapper = placo.RobotWrapper(str(robot.urdf_path), placo.Flags.ignore_collisions)
    assert set(addresses.body_ids) == set(robot.frames)
    rng = np.random.default_rng(7)
    limits = robot.position_limits(robot.movable_joints)
    max_pos = max_rot = 0.0
    for _ in range(200):
        q = rng.uniform(limits[:, 0], limits[:, 1])
        for joint, value in zip(robot.movable_joints, q, strict=True):
            wrapper.set_joint(joint, value)
            data.qpos[addresses.joint_qpos[joint]] = value
        wrapper.update_kinematics()
        mujoco.mj_kinematics(model, data)
        for link, body in addresses.body_ids.items():
            T = wrapper.get_T_world_frame(link)
            R = data.xmat[body].reshape(3, 3)
            max_pos = max(max_pos, float(np.abs(T[:3, 3] - data.xpos[body]).max()))
            max_rot = max(max_rot, float(np.linalg.norm(T[:3, :3].T @ R - np.eye(3))))
    assert max_pos < 1e-9, f"{robot.name}: position error {max_pos:.3g} m"
    assert max_rot < 1e-9, f"{robot.name}: rotation error {max_rot:.3g}"


def test_attached_robot_keeps_names_and_kinematics(robot: RobotModel) -> None:
    """Attached under a prefix and a mount frame, the robot's frames move with the mount."""
    scene = mujoco.MjSpec()
    configure_contact_options(scene)
    mount = np.array([0.1, -0.8, -0.7])
    frame = scene.worldbody.add_frame(pos=mount, quat=[np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)])
    scene.attach(build_robot_spec(robot), frame=frame, prefix="robot/")
    model = scene.compile()
    data = mujoco.MjData(model)
    addresses = robot_addresses(model, robot, prefix="robot/")
    set_configuration(model, data, addresses, robot.home_configuration())
    mujoco.mj_forward(model, data)
    assert np.allclose(data.xpos[addresses.root_body], mount)
    # yaw 90 deg: the robot's forward (+x) is world +y
    assert np.allclose(data.xmat[addresses.root_body].reshape(3, 3)[:, 0], [0, 1, 0])
    assert model.nu == len(robot.actuated_joints) + len(robot.arms)
    assert data.ncon == 0, "the robot touches itself at home"


def test_no_self_contact_at_home(robot: RobotModel) -> None:
    model, data, _ = _standalone(robot)
    assert data.ncon == 0, [
        (model.geom(data.contact[i].geom1).name, model.geom(data.contact[i].geom2).name)
        for i in range(data.ncon)
    ]


def _standalone(robot: RobotModel) -> tuple[mujoco.MjModel, mujoco.MjData, object]:
    spec = build_robot_spec(robot)
    configure_contact_options(spec)
    model = spec.compile()
    data = mujoco.MjData(model)
    addresses = robot_addresses(model, robot)
    set_configuration(model, data, addresses, robot.home_configuration())
    mujoco.mj_forward(model, data)
    return model, data, addresses


@pytest.mark.parametrize(("name", "arm_name"), ARMS)
def test_gripper_opens_to_nominal_width_and_closes(name: str, arm_name: str) -> None:
    robot = RobotModel.load(name)
    arm = robot.arms[arm_name]
    model, data, addresses = _standalone(robot)
    a: ArmAddresses = addresses.arms[arm_name]
    # Start closed, command open, then closed again (gravity on, arms holding home).
    for index in a.finger_qpos:
        data.qpos[index] = arm.finger_closed_position
    data.ctrl[a.gripper_ctrl] = arm.finger_closed_position
    mujoco.mj_forward(model, data)
    assert pad_gap(model, data, a) == pytest.approx(arm.closed_width, abs=2e-3)
    data.ctrl[a.gripper_ctrl] = arm.finger_open_position
    mujoco.mj_step(model, data, nstep=500)
    opened = pad_gap(model, data, a)
    assert opened == pytest.approx(arm.open_width, abs=2e-3), f"opened to {opened:.4f} m"
    fingers = data.qpos[list(a.finger_qpos)]
    assert fingers[0] == pytest.approx(fingers[1], abs=1e-3), "fingers not coupled"
    data.ctrl[a.gripper_ctrl] = arm.finger_closed_position
    mujoco.mj_step(model, data, nstep=500)
    closed = pad_gap(model, data, a)
    assert closed == pytest.approx(arm.closed_width, abs=2e-3), f"closed to {closed:.4f} m"


def _hold_scene(
    robot: RobotModel, arm_name: str, size: float = CUBE_SIZE
) -> tuple[mujoco.MjModel, mujoco.MjData, object]:
    """The robot at home with a free cube of edge ``size`` centred on the arm's TCP, faces
    along the EE axes."""
    model, data, addresses = _standalone(robot)
    a = addresses.arms[arm_name]
    tcp = data.xpos[a.tcp_body].copy()
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, data.xmat[a.tcp_body])
    spec = build_robot_spec(robot)
    configure_contact_options(spec)
    cube = spec.worldbody.add_body(name="cube", pos=tcp, quat=quat)
    cube.add_freejoint(name="cube_free")
    cube.add_geom(
        name="cube_geom",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[size / 2] * 3,
        mass=CUBE_MASS,
        friction=[1.0, 0.005, 0.0001],
        condim=4,
    )
    model = spec.compile()
    data = mujoco.MjData(model)
    addresses = robot_addresses(model, robot)
    set_configuration(model, data, addresses, robot.home_configuration())
    mujoco.mj_forward(model, data)
    return model, data, addresses


def _cube_in_tcp_frame(model: mujoco.MjModel, data: mujoco.MjData, a: ArmAddresses) -> np.ndarray:
    cube = model.body("cube").id
    R = data.xmat[a.tcp_body].reshape(3, 3)
    return R.T @ (data.xpos[cube] - data.xpos[a.tcp_body])


@pytest.mark.parametrize(("name", "arm_name"), ARMS)
def test_gripper_holds_cube_for_5_s(name: str, arm_name: str) -> None:
    """Close on a 4 cm, 0.1 kg cube with gravity off, then hold 5 s under gravity: slip < 5 mm."""
    robot = RobotModel.load(name)
    arm = robot.arms[arm_name]
    model, data, addresses = _hold_scene(robot, arm_name)
    a = addresses.arms[arm_name]
    assert model.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC and model.opt.impratio == 10.0
    gravity = model.opt.gravity.copy()
    model.opt.gravity[:] = 0.0
    data.ctrl[a.gripper_ctrl] = arm.finger_closed_position
    mujoco.mj_step(model, data, nstep=250)
    gap = pad_gap(model, data, a)
    assert gap == pytest.approx(CUBE_SIZE, abs=2e-3), f"pads at {gap:.4f} m on a 4 cm cube"
    cube = model.body("cube").id
    finger_force = _finger_normal_forces(model, data, a, cube)
    assert min(finger_force) > 1.0, f"finger normal forces {finger_force}"
    model.opt.gravity[:] = gravity
    start = _cube_in_tcp_frame(model, data, a)
    mujoco.mj_step(model, data, nstep=2500)  # 5 s
    slip = float(np.linalg.norm(_cube_in_tcp_frame(model, data, a) - start))
    assert slip < 5e-3, f"{name} {arm_name}: cube slipped {slip * 1e3:.2f} mm in 5 s"
    assert min(_finger_normal_forces(model, data, a, cube)) > 1.0


def squeeze_per_pad(name: str, arm_name: str, width: float) -> tuple[float, float]:
    """Close the gripper as the executor does (to the closed width, then the squeeze target)
    on a cube of edge ``width``, gravity off, 0.5 s each: the two pads' normal forces (N)."""
    robot = RobotModel.load(name)
    arm = robot.arms[arm_name]
    model, data, addresses = _hold_scene(robot, arm_name, width)
    a = addresses.arms[arm_name]
    model.opt.gravity[:] = 0.0
    data.ctrl[a.gripper_ctrl] = arm.finger_closed_position
    mujoco.mj_step(model, data, nstep=250)
    data.ctrl[a.gripper_ctrl] = arm.finger_squeeze_position
    mujoco.mj_step(model, data, nstep=250)
    left, right = _finger_normal_forces(model, data, a, model.body("cube").id)
    return left, right


@pytest.mark.parametrize(("name", "arm_name"), list({n: (n, a) for n, a in ARMS}.values()))
@pytest.mark.parametrize("width", [0.01, 0.04, 0.06])
def test_force_grasp_squeezes_with_the_force_limit_at_every_width(
    name: str, arm_name: str, width: float
) -> None:
    """A force-controlled grasp (robot.yaml ``grasp: force``) presses each pad with the
    gripper's force_limit whatever the object's width (docs/robots.md, the squeeze table):
    FR3 70 N (Franka Hand datasheet), Lift-2 and Split ALOHA 5 N (Menagerie +-10 N)."""
    limit = RobotModel.load(name).arms[arm_name].gripper.force_limit
    left, right = squeeze_per_pad(name, arm_name, width)
    assert left == pytest.approx(limit, rel=0.03) and right == pytest.approx(limit, rel=0.03)


def _finger_normal_forces(
    model: mujoco.MjModel, data: mujoco.MjData, a: ArmAddresses, body: int
) -> list[float]:
    """Summed contact normal force between ``body`` and each finger (N)."""
    forces = [0.0, 0.0]
    wrench = np.zeros(6)
    for i in range(data.ncon):
        contact = data.contact[i]
        bodies = {model.geom_bodyid[contact.geom1], model.geom_bodyid[contact.geom2]}
        if body not in bodies:
            continue
        for k, finger in enumerate(a.finger_bodies):
            if finger in bodies:
                mujoco.mj_contactForce(model, data, i, wrench)
                forces[k] += float(wrench[0])
    return forces
