"""Robot models: robot.yaml vs URDF, reference conventions, home poses, gripper frames, errors."""

from __future__ import annotations

import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np
import placo
import pytest
import yaml
from helpers import AVAILABLE_ROBOTS_TEXT, ROBOTS, canonical_filters
from reference_robots import (
    APPROACH_AT_HOME,
    ARM_NAMES,
    ARM_SPACING,
    EE_LINKS,
    INTERNDATA_CONFIG_FILES,
    LINK_MASSES,
    OPEN_WIDTHS,
    PLACEMENTS,
    REFERENCE_ARM_BASES,
    REFERENCE_CONVENTIONS,
    REFERENCE_ROBOTS,
    TCP_FRAME_OFFSET,
    pinned,
)
from scipy.spatial.transform import Rotation

from harness.config import AxisFilter, ConfigError
from harness.config.robot_registry import canonical_task_files
from harness.errors import HarnessError
from harness.grasps import filter_ee_poses, load_grasp_file, post_process
from harness.robots import ROBOTS_DIR, RobotModel, available_robots
from harness.robots.facts import (
    interndata_home,
    interndata_robots,
    max_jaw_opening,
    reference_convention,
    robot_arms,
)
from harness.robots.generator.collisions import candidate_pairs
from harness.robots.generator.generate import build_robot, generated_robots
from harness.robots.generator.urdf_text import urdf_text
from harness.robots.mujoco_spec import build_robot_spec, robot_addresses, set_configuration
from harness.robots.spec import (
    ActuatorGains,
    ArmSpec,
    ConventionSpec,
    GripperActuator,
    InternDataSpec,
    LiftSpec,
    RobotFile,
    TimingLimits,
)

AXIS = {"x": 0, "y": 1, "z": 2}


@pytest.fixture(scope="module", params=ROBOTS)
def robot(request: pytest.FixtureRequest) -> RobotModel:
    return RobotModel.load(request.param)


def _placo(robot: RobotModel) -> placo.RobotWrapper:
    wrapper = placo.RobotWrapper(str(robot.urdf_path), placo.Flags.ignore_collisions)
    for joint, value in robot.home_configuration().items():
        wrapper.set_joint(joint, value)
    wrapper.update_kinematics()
    return wrapper


# --------------------------------------------------------------------------------------------
# Loading and the reference values


def test_available_robots_are_the_robot_folders_each_with_a_task() -> None:
    """The registry lists every robots/<name>/ with a robot.yaml (not the _template), sorted;
    each has its URDF, its collision pairs and at least one canonical task file."""
    folders = sorted(
        p.parent.name for p in ROBOTS_DIR.glob("*/robot.yaml") if not p.parent.name.startswith("_")
    )
    assert available_robots() == folders and set(REFERENCE_ROBOTS) <= set(folders)
    assert "_template" not in available_robots()
    for name in folders:
        assert (ROBOTS_DIR / name / f"{name}.urdf").is_file(), name
        assert (ROBOTS_DIR / name / "collisions.json").is_file(), name
        assert canonical_task_files(name), f"{name}: no tasks/pick/{name}[_<arm>].yaml"


def test_load_by_name_path_and_folder(robot: RobotModel) -> None:
    by_path = RobotModel.load(robot.yaml_path)
    by_folder = RobotModel.load(str(robot.yaml_path.parent))
    assert by_path.urdf_path == by_folder.urdf_path == robot.urdf_path
    assert robot.urdf_path == ROBOTS_DIR / robot.name / f"{robot.name}.urdf"


def test_convention_equals_reference(robot: RobotModel) -> None:
    ours, ref = robot.convention, pinned(REFERENCE_CONVENTIONS, robot.name)
    np.testing.assert_array_equal(ours.R_ee_graspnet, ref.R_ee_graspnet)
    assert (ours.ee_axis, ours.facing_axis, ours.approach_axis) == (
        ref.ee_axis,
        ref.facing_axis,
        ref.approach_axis,
    )
    assert ours.tcp_offset == ref.tcp_offset
    assert (ours.gripper_min_width, ours.gripper_max_width) == (
        ref.gripper_min_width,
        ref.gripper_max_width,
    )


def test_arm_names_frames_and_home(robot: RobotModel) -> None:
    assert list(robot.arms) in (["left"], ["left", "right"])
    if robot.name in ARM_NAMES:
        assert list(robot.arms) == ARM_NAMES[robot.name]
    q = robot.home_configuration()
    assert set(q) == set(robot.movable_joints)
    for joint, value in q.items():
        lo, hi = robot.joint_limits(joint)
        assert lo <= value <= hi, joint
    for arm in robot.arms.values():
        assert arm.base_frame == f"{arm.name}_arm_base"
        assert arm.tcp_frame == f"{arm.name}_tcp"
        assert arm.ee_frame in robot.frames
        if robot.name in EE_LINKS:
            assert arm.ee_frame == f"{arm.name}_{EE_LINKS[robot.name]}"
        for finger in arm.finger_joints:
            assert q[finger] == pytest.approx(arm.open_width / 2)
    assert robot.root_frame == "base"


def test_reference_homes_and_widths() -> None:
    fr3, lift2, aloha = (
        RobotModel.load("fr3"),
        RobotModel.load("lift2"),
        RobotModel.load("split_aloha"),
    )
    assert fr3.arms["left"].home == [0.0, -0.143, 0.0, -2.435, 0.0, 2.235, 0.789]
    assert lift2.lift_joint == "lift_joint" and lift2.lift_home == 0.46
    assert lift2.joint_limits("lift_joint") == (0.0, 0.46)
    assert all(abs(v) < 0.006 for v in lift2.arms["right"].home)
    assert aloha.arms["left"].home_noise_std[1] == pytest.approx(0.24539099)
    widths = {name: RobotModel.load(name).arms["left"].open_width for name in OPEN_WIDTHS}
    # The reference's jaws; the Split ALOHA default is its piper100 (the SDK's 0.07: sdk070).
    assert widths == OPEN_WIDTHS
    # Known typo fixed: Piper J1 upper 2.168 -> 2.618.
    assert aloha.joint_limits("left_joint1") == (-2.618, 2.618)
    # Lift-2 arms: the Lift-2 URDF's ranges (the robot the reference simulates), not R5a.urdf's.
    assert lift2.joint_limits("right_joint1") == (-2.094, 3.1416)
    assert lift2.joint_limits("left_joint4") == (-1.671, 1.671)
    assert lift2.joint_limits("left_joint6") == (-2.094, 2.094)
    # FR3: the older (franka_description / Menagerie) table.
    assert fr3.joint_limits("left_joint4") == (-3.0421, -0.1518)
    assert fr3.joint_limits("left_joint6") == (0.5445, 4.5169)
    assert fr3.velocity_limit("left_joint5") == 5.26
    assert fr3.jerk_limit("left_joint1") == 5000.0


def test_placements_follow_reference_offsets() -> None:
    for name, (y, z_range) in PLACEMENTS.items():
        placement = RobotModel.load(name).placement
        lo, hi = placement.pos_range
        assert (lo[1], hi[1]) == y and (lo[2], hi[2]) == z_range
        assert placement.yaw_range == (90.0, 90.0)


# --------------------------------------------------------------------------------------------
# Kinematics at home (placo)


def test_tcp_is_tcp_offset_along_the_approach_axis_at_home(robot: RobotModel) -> None:
    wrapper = _placo(robot)
    axis = AXIS[robot.convention.approach_axis]
    for arm in robot.arms.values():
        T_ee_tcp = wrapper.get_T_a_b(arm.ee_frame, arm.tcp_frame)
        expected = np.zeros(3)
        expected[axis] = pinned(TCP_FRAME_OFFSET, robot.name)
        np.testing.assert_allclose(T_ee_tcp[:3, 3], expected, atol=1e-12)
        np.testing.assert_allclose(T_ee_tcp[:3, :3], np.eye(3), atol=1e-12)
    # fr3: the frame is Franka's 0.1034; the reference convention keeps its 0.1043 (sic).
    delta = robot.convention.tcp_offset - TCP_FRAME_OFFSET[robot.name]
    assert delta == pytest.approx(0.0009 if robot.name == "fr3" else 0.0, abs=1e-12)


def test_approach_axis_direction_at_home(robot: RobotModel) -> None:
    """fr3 points down; split_aloha forward and 15 deg down; lift2 straight forward."""
    wrapper = _placo(robot)
    axis = AXIS[robot.convention.approach_axis]
    expected = pinned(APPROACH_AT_HOME, robot.name)
    for arm in robot.arms.values():
        approach = wrapper.get_T_a_b(arm.base_frame, arm.ee_frame)[:3, axis]
        np.testing.assert_allclose(approach, expected, atol=2e-3)


def test_arm_base_frames_face_forward_and_up(robot: RobotModel) -> None:
    wrapper = _placo(robot)
    for arm in robot.arms.values():
        R = wrapper.get_T_a_b(robot.root_frame, arm.base_frame)[:3, :3]
        np.testing.assert_allclose(R, np.eye(3), atol=1e-12)
    if len(robot.arms) == 2:
        left = wrapper.get_T_a_b(robot.root_frame, "left_arm_base")[:3, 3]
        right = wrapper.get_T_a_b(robot.root_frame, "right_arm_base")[:3, 3]
        assert left[1] > right[1]
        spacing = pinned(ARM_SPACING, robot.name)
        assert left[1] - right[1] == pytest.approx(spacing, abs=1e-9)


def test_arm_bases_sit_where_the_reference_puts_them(robot: RobotModel) -> None:
    """x, y from the reference's LeRobot converters; heights: see tests/reference_robots.py."""
    expected_bases = pinned(REFERENCE_ARM_BASES, robot.name)
    model = build_robot_spec(robot).compile()
    data = mujoco.MjData(model)
    set_configuration(model, data, robot_addresses(model, robot), robot.home_configuration())
    mujoco.mj_kinematics(model, data)
    root = data.body(robot.root_frame)
    for arm_name, expected in expected_bases.items():
        base = data.body(robot.arms[arm_name].base_frame)
        in_root = root.xmat.reshape(3, 3).T @ (base.xpos - root.xpos)
        np.testing.assert_allclose(in_root, expected, atol=5e-6)


def test_fingers_travel_along_the_grasp_closing_axis(robot: RobotModel) -> None:
    """The EE axis R_ee_graspnet maps g_y (closing) onto is the axis the fingers slide along,
    the approach (g_x) runs from the EE through the pad midpoint, at random configurations."""
    spec = build_robot_spec(robot)
    model = spec.compile()
    data = mujoco.MjData(model)
    addresses = robot_addresses(model, robot)
    R_ee_g = robot.convention.R_ee_graspnet  # grasp coordinates -> EE coordinates
    closing_in_ee, approach_in_ee = R_ee_g[:, 1], R_ee_g[:, 0]
    rng = np.random.default_rng(3)
    limits = robot.position_limits(robot.movable_joints)
    for _ in range(20):
        q = dict(zip(robot.movable_joints, rng.uniform(limits[:, 0], limits[:, 1]), strict=True))
        for arm in robot.arms.values():  # the fingers are coupled in MuJoCo
            q[arm.finger_joints[1]] = q[arm.finger_joints[0]]
        set_configuration(model, data, addresses, q)
        mujoco.mj_kinematics(model, data)
        for a in addresses.arms.values():
            R_ee = data.xmat[a.ee_body].reshape(3, 3)
            slide = R_ee.T @ data.xaxis[a.finger_joint_ids[0]]
            assert abs(slide @ closing_in_ee) == pytest.approx(1.0, abs=1e-9)
            midpoint = (data.geom_xpos[a.pad_geoms[0]] + data.geom_xpos[a.pad_geoms[1]]) / 2
            offset = R_ee.T @ (midpoint - data.xpos[a.ee_body])
            along = offset @ approach_in_ee
            assert along > 0.09
            np.testing.assert_allclose(offset, along * approach_in_ee, atol=5e-4)


def test_canonical_filters_select_the_same_grasps(example_objects: list[Path]) -> None:
    """Reference section 11: with robot.yaml's conventions, FR3 x-forward-90 + z-downward-140,
    Lift-2 x-downward-140 + z-forward-90 and Split ALOHA y-forward-90 + z-downward-140 keep
    the same poses for the same object pose in each arm's base frame."""
    canonical = {name: canonical_filters(name) for name in REFERENCE_ROBOTS}
    rng = np.random.default_rng(11)
    for folder in example_objects[:4]:
        grasps = load_grasp_file(folder / "Aligned_grasp_sparse.npy")
        for _ in range(3):
            T_base_obj = np.eye(4)
            T_base_obj[:3, :3] = Rotation.random(random_state=rng).as_matrix()
            T_base_obj[:3, 3] = [0.45, 0.1, 0.05]
            masks = {}
            for name, filters in canonical.items():
                convention = RobotModel.load(name).convention
                poses = post_process(grasps, convention)
                specs = {k: AxisFilter(direction=d, angles=(a,)) for k, (d, a) in filters.items()}
                masks[name] = filter_ee_poses(poses, T_base_obj, specs).combined
            assert masks["fr3"].any()
            for name in REFERENCE_ROBOTS:
                np.testing.assert_array_equal(masks["fr3"], masks[name], err_msg=name)


# --------------------------------------------------------------------------------------------
# URDF properties


def _inertials(urdf: Path) -> dict[str, tuple[float, np.ndarray]]:
    out = {}
    for link in ET.parse(urdf).getroot().findall("link"):
        inertial = link.find("inertial")
        if inertial is None:
            continue
        mass = float(inertial.find("mass").get("value"))
        i = {k: float(v) for k, v in inertial.find("inertia").attrib.items()}
        out[link.get("name")] = (
            mass,
            np.array(
                [
                    [i["ixx"], i["ixy"], i["ixz"]],
                    [i["ixy"], i["iyy"], i["iyz"]],
                    [i["ixz"], i["iyz"], i["izz"]],
                ]
            ),
        )
    return out


def test_inertials_are_physical_with_reference_masses(robot: RobotModel) -> None:
    inertials = _inertials(robot.urdf_path)
    for link, (mass, inertia) in inertials.items():
        assert mass > 0
        principal = np.linalg.eigvalsh(inertia)
        assert principal.min() > 0, link
        assert 2 * principal.max() <= principal.sum() * (1 + 1e-9), f"{link}: triangle inequality"
    masses = {link: m for link, (m, _) in inertials.items()}
    for link, mass in pinned(LINK_MASSES, robot.name).items():
        assert masses[link] == mass, link
    for arm in robot.arms.values():  # massless planning frames
        assert arm.base_frame not in masses and arm.tcp_frame not in masses


def test_the_template_folder_is_a_working_robot(tmp_path: Path) -> None:
    """robots/_template/ (build.py + robot.yaml) builds and loads like a robot, so copying it
    starts from a valid folder; its robot.yaml names every key of the schema."""
    template = ROBOTS_DIR / "_template"
    spec = importlib.util.spec_from_file_location("template_build", template / "build.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    robot_urdf = module.build()
    assert robot_urdf.name == "_template"
    (tmp_path / "_template.urdf").write_text(urdf_text(robot_urdf))
    (tmp_path / "collisions.json").write_text("[]\n")
    shutil.copy(template / "robot.yaml", tmp_path / "robot.yaml")
    robot = RobotModel.load(tmp_path / "robot.yaml")
    assert list(robot.arms) == ["left"] and robot.arms["left"].open_width == 0.08
    text = (template / "robot.yaml").read_text()
    keys = set(re.findall(r"^[# ]*([A-Za-z_]+):", text, re.M))
    for model in (RobotFile, ArmSpec, GripperActuator, LiftSpec, ConventionSpec, InternDataSpec):
        missing = set(model.model_fields) - keys
        assert not missing, f"robots/_template/robot.yaml does not name {sorted(missing)}"
    for model in (ActuatorGains, TimingLimits):
        assert set(model.model_fields) <= keys


def test_committed_urdfs_equal_the_generator_output(robot: RobotModel) -> None:
    if robot.name not in generated_robots():
        pytest.skip(f"robots/{robot.name} has no build.py (its URDF is not generated here)")
    text = urdf_text(build_robot(robot.name))
    assert robot.urdf_path.read_text() == text, "run python robots/build_urdfs.py"


def test_collision_pairs_are_clear_at_home_and_not_adjacent(robot: RobotModel) -> None:
    pairs = json.loads(robot.collisions_path.read_text())
    assert pairs, "no self-collision pairs"
    links = set(robot.frames)
    if robot.name in generated_robots():
        candidates = candidate_pairs(build_robot(robot.name))
        assert sorted(map(sorted, pairs)) == sorted(map(sorted, candidates))
    for a, b in pairs:
        assert a in links and b in links
    wrapper = placo.RobotWrapper(str(robot.urdf_path), placo.Flags.ignore_collisions)
    wrapper.load_collision_pairs(str(robot.collisions_path))
    for joint, value in robot.home_configuration().items():
        wrapper.set_joint(joint, value)
    wrapper.update_kinematics()
    assert len(wrapper.self_collisions(False)) == 0


# --------------------------------------------------------------------------------------------
# Command line


def test_robots_list_and_show(capsys: pytest.CaptureFixture[str]) -> None:
    from harness.cli import main

    assert main(["robots", "list"]) == 0
    out = capsys.readouterr().out
    assert all(name in out for name in ROBOTS)
    assert main(["robots", "show", "lift2"]) == 0
    out = capsys.readouterr().out
    assert "lift lift_joint: range 0.0-0.46 m, home 0.46" in out
    # root y -0.80 + 0.163 (the reference converter)
    assert "right arm base at [0.248, -0.637, 0.032]" in out
    assert main(["robots", "show", "ur5"]) == 2
    assert f"available robots: {AVAILABLE_ROBOTS_TEXT}" in capsys.readouterr().err


def test_robots_show_renders_a_png(tmp_path: Path) -> None:
    """Offscreen render in a fresh process (MuJoCo picks its GL backend at import)."""
    out = tmp_path / "fr3.png"
    env = {k: v for k, v in os.environ.items() if k != "MUJOCO_GL"}
    code = "import sys; from harness.cli import main; sys.exit(main(sys.argv[1:]))"
    result = subprocess.run(
        [sys.executable, "-c", code, "robots", "show", "fr3", "--render", str(out)],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    from PIL import Image

    image = np.asarray(Image.open(out))
    assert image.shape == (720, 960, 3)
    assert image.std() > 20  # not a blank frame
    turned = tmp_path / "fr3-turned.png"
    view = ["--distance", "2.6", "--azimuth", "30", "--elevation", "-45"]
    result = subprocess.run(
        [sys.executable, "-c", code, "robots", "show", "fr3", "--render", str(turned), *view],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    other = np.asarray(Image.open(turned))
    assert other.shape == image.shape and other.std() > 20
    assert np.mean(np.abs(other.astype(float) - image)) > 10  # another viewpoint


@pytest.mark.parametrize(
    ("flag", "value", "says"),
    [
        ("--azimuth", "nan", "'nan' is not a finite number"),
        ("--elevation", "inf", "'inf' is not a finite number"),
        ("--distance", "0", "0 is not positive"),
        ("--distance", "far", "'far' is not a number"),
    ],
)
def test_robots_show_refuses_a_camera_that_is_no_finite_number(
    flag: str, value: str, says: str, capsys: pytest.CaptureFixture[str]
) -> None:
    from harness.cli import main

    with pytest.raises(SystemExit) as stop:
        main(["robots", "show", "fr3", "--render", "x.png", flag, value])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert f"argument {flag}: {says}" in err.splitlines()[-1]


# --------------------------------------------------------------------------------------------
# Errors


def test_unknown_robot_lists_the_available_ones() -> None:
    with pytest.raises(
        HarnessError, match=f"unknown robot 'ur5'; available robots: {AVAILABLE_ROBOTS_TEXT}"
    ):
        RobotModel.load("ur5")
    with pytest.raises(HarnessError, match="robot file not found"):
        RobotModel.load("no/such/robot.yaml")
    with pytest.raises(HarnessError, match="has no arm 'right'"):
        RobotModel.load("fr3").arm("right")


def _copy_robot(tmp_path: Path, name: str, old: str, new: str) -> Path:
    folder = tmp_path / name
    shutil.copytree(ROBOTS_DIR / name, folder)
    path = folder / "robot.yaml"
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))
    return path


def test_joint_missing_from_urdf_names_file_and_key(tmp_path: Path) -> None:
    path = _copy_robot(tmp_path, "lift2", "left_joint3,", "left_joint33,")
    with pytest.raises(ConfigError) as info:
        RobotModel.load(path)
    error = info.value
    assert error.file == str(path) and error.key == "arms.left.joints[2]"
    assert "'left_joint33' is not in the URDF" in str(error)
    assert str(error).startswith(f"{path}:")


@pytest.mark.parametrize(
    ("old", "new", "key", "message"),
    [
        ("ee_frame: left_hand", "ee_frame: left_palm", "arms.left.ee_frame", "not a link"),
        ("home: [0.0, -0.143", "home: [0.0, -1.9", "arms.left.home[1]", "outside"),
        ("velocity: [2.62,", "velocity: [9.0,", "arms.left.limits.velocity[0]", "exceeds"),
        ("open_width: 0.08", "open_width: 0.09", "arms.left.open_width", "per finger"),
        ("tcp_offset: 0.1043", "tcp_ofset: 0.1043", "convention.tcp_ofset", "unknown key"),
        ("approach_axis: z", "approach_axis: x", "convention", "must equal ee_axis"),
        ("frictionloss: [1.137,", "frictionloss: [", "arms.left", "entries for 7 joints"),
        ("left: [0.0, -0.785, 0.0,", "left: [0.0,", "interndata.home.left", "5 values for 7 arm"),
        ("  home:\n    left:", "  home:\n    right:", "interndata.home.right", "no right arm"),
    ],
)
def test_bad_robot_yaml_is_located(
    tmp_path: Path, old: str, new: str, key: str, message: str
) -> None:
    path = _copy_robot(tmp_path, "fr3", old, new)
    with pytest.raises(ConfigError) as info:
        RobotModel.load(path)
    assert info.value.file == str(path)
    assert info.value.key == key
    assert message in str(info.value)


def test_robot_facts_come_from_the_robot_folders() -> None:
    """Every robot fact a tool needs is read from robots/<name>/robot.yaml (no Python tables)."""
    for name, config_file in INTERNDATA_CONFIG_FILES.items():
        assert interndata_robots()[config_file] == name
    assert robot_arms("fr3") == ("left",) and robot_arms("lift2") == ("left", "right")
    assert interndata_home("fr3", "left") == [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]
    assert interndata_home("split_aloha", "right") == [0.0] * 6
    assert {r: max_jaw_opening(r) for r in OPEN_WIDTHS} == OPEN_WIDTHS
    for robot, expected in REFERENCE_CONVENTIONS.items():
        convention = reference_convention(robot)
        assert convention.tcp_offset == expected.tcp_offset
        np.testing.assert_array_equal(convention.R_ee_graspnet, expected.R_ee_graspnet)


# Physical values that must carry a source in every bundled robot.yaml (robots/<name>/robot.yaml
# ``sources``): the grip, the placement, the body facts the issue of reference fidelity named.
REQUIRED_SOURCES = (
    "placement.pos_range",
    "convention",
    "urdf.arm_joint_ranges",
    "urdf.fingertip",
    "arms.*.gripper.force_limit",
    "arms.*.gripper.pad_friction",
)


@pytest.mark.parametrize("name", ROBOTS)
def test_every_physical_value_carries_a_source(name: str) -> None:
    from harness.robots.spec import RobotFile

    data = yaml.safe_load((ROBOTS_DIR / name / "robot.yaml").read_text(encoding="utf-8"))
    spec = RobotFile.model_validate(data)
    keys = set(spec.sources)
    for required in REQUIRED_SOURCES:
        arm_keys = {required.replace("arms.*.", f"arms.{a}.") for a in spec.arms}
        assert required in keys or arm_keys <= keys, f"{name}: no source for {required}"
    assert all(text.strip() for text in spec.sources.values())
    # an unknown names the task key that sweeps it
    for key, axis in spec.unsourced().items():
        if key.endswith(("force_limit", "pad_friction", "mount_height")):
            assert axis, f"{name}: {key} has no primary source and names no sweep axis"


def test_sources_name_real_keys() -> None:
    from harness.robots.spec import RobotFile

    data = yaml.safe_load((ROBOTS_DIR / "fr3" / "robot.yaml").read_text(encoding="utf-8"))
    data["sources"]["arms.*.gripper.grip"] = "a typo"
    with pytest.raises(ValueError, match=re.escape("arms.*.gripper.grip")):
        RobotFile.model_validate(data)


def test_grip_forces_are_the_derived_ones() -> None:
    # arx5-sdk: gripper_torque_max 1.5 N m over gripper_open_readout 5.03 rad for 0.088 m
    ideal_r5a = 1.5 / (0.088 / 5.03)
    assert ideal_r5a == pytest.approx(85.7, abs=0.05)
    r5a = RobotModel.load("lift2").arms["left"].gripper
    assert r5a.force_limit == pytest.approx(ideal_r5a, abs=0.05)
    assert RobotModel.load("fr3").arms["left"].gripper.force_limit == 70.0  # Franka Hand datasheet
