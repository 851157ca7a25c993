"""Scene: composition, placement from the task's ranges, home noise, settling, state queries.

The synthetic box object and the canonical task come from ``tests/helpers.py`` (shared with the
other pick tests), so the scene tests do not depend on the default object set.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
from helpers import make_task, write_box

from harness.config import PhysicsConfig, TaskConfig
from harness.sim import TABLE_NAME, Scene
from harness.transforms import invert_T


@pytest.fixture(scope="session")
def cube_mesh(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 4 cm cube with antipodal grasps."""
    return write_box(tmp_path_factory.mktemp("cube"), (0.04, 0.04, 0.04), "cube")


# --------------------------------------------------------------------------------------------
# Tests


@pytest.fixture(scope="module")
def fr3_scene(cube_mesh: Path) -> tuple[Scene, TaskConfig]:
    task = make_task("fr3", "left", cube_mesh)
    return Scene.build(task.robot, task.objects, task.physics, task.base_dir()), task


def test_build_composes_robot_table_object(fr3_scene: tuple[Scene, TaskConfig]) -> None:
    scene, task = fr3_scene
    m = scene.model
    assert m.opt.timestep == pytest.approx(0.002)
    assert m.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC
    assert m.opt.impratio == pytest.approx(10.0)
    assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, TABLE_NAME) >= 0
    obj = scene.objects["target"]
    assert task.objects[0].mass is None  # an OBJ mesh authors no mass: the default 0.1 kg
    assert m.body_mass[obj.body_id] == pytest.approx(0.1) == obj.asset.mass
    assert m.body_mocapid[scene.root_body] == 0  # the robot root is the (only) mocap body
    assert set(scene.arms) == {"left"}
    assert len(scene.arms["left"].active_names) == 7


def test_reset_is_deterministic_and_within_the_ranges(fr3_scene: tuple[Scene, TaskConfig]) -> None:
    scene, task = fr3_scene
    first = scene.reset(task, np.random.default_rng(5))
    q_first = scene.data.qpos.copy()
    second = scene.reset(task, np.random.default_rng(5))
    assert np.array_equal(q_first, scene.data.qpos)
    assert np.allclose(first.T_world_root, second.T_world_root)
    lo, hi = (np.asarray(v) for v in scene.robot.placement.pos_range)
    region = scene.robot.arm("left").object_region
    olo, ohi = (np.asarray(v) for v in region.pos_range)
    for seed in range(20):
        state = scene.reset(task, np.random.default_rng(seed))
        root = state.T_world_root[:3, 3]
        assert np.all(root >= lo - 1e-12) and np.all(root <= hi + 1e-12)
        # Robot yaw 90 deg: it faces +y.
        assert np.allclose(state.T_world_root[:3, 0], [0.0, 1.0, 0.0], atol=1e-9)
        obj = scene.T_world_object("target")[:3, 3]
        assert np.all(obj[:2] >= olo[:2] - 2e-3) and np.all(obj[:2] <= ohi[:2] + 2e-3)
        # Settled on the table: the cube's centre 2 cm up, resting.
        assert obj[2] == pytest.approx(0.02, abs=1e-3)
        assert np.linalg.norm(scene.object_velocity("target")[:3]) < 0.05
        assert state.object_init_position[2] == pytest.approx(0.021, abs=1e-6)


def test_init_position_is_recorded_after_one_reference_step(
    fr3_scene: tuple[Scene, TaskConfig],
) -> None:
    """The reference builds the skill (recording obj_init_trans) one 1/30 s physics step after
    placing: the cube placed 1 mm up (centre at 21 mm) has landed by then (MuJoCo's soft contact
    still has it ~1 mm into the table top, mid-impact). The settle steps follow the record."""
    scene, task = fr3_scene
    timestep = scene.model.opt.timestep
    state = scene.reset(task, np.random.default_rng(3), settle_time=0.2, init_record_time=1 / 30)
    assert state.object_init_position[2] == pytest.approx(0.02, abs=1.5e-3)
    assert state.object_init_position[2] < 0.0205  # no longer 1 mm up
    assert state.settle_steps == round((1 / 30) / timestep) + round(0.2 / timestep)
    assert scene.data.time == pytest.approx(state.settle_steps * timestep)


def test_home_noise_matches_the_configured_std(fr3_scene: tuple[Scene, TaskConfig]) -> None:
    scene, task = fr3_scene
    arm = scene.robot.arm("left")
    draws = np.array(
        [
            [scene.home_configuration(task, np.random.default_rng(s))[j] for j in arm.joints]
            for s in range(400)
        ]
    )
    assert np.allclose(draws.mean(axis=0), arm.home, atol=0.01)
    assert np.allclose(draws.std(axis=0), arm.home_noise_std, rtol=0.2)
    home = [value + 0.05 for value in arm.home]
    quiet = task.model_copy(update={"home_noise_std": [0.0] * 7, "home": home})
    q = scene.home_configuration(quiet, np.random.default_rng(0))
    assert [q[j] for j in arm.joints] == pytest.approx(home)


def test_task_placement_and_orientation_override(cube_mesh: Path) -> None:
    """Task ranges override robot.yaml's; orientation choices are drawn per episode."""
    task = make_task(
        "fr3",
        "left",
        cube_mesh,
        object={
            "placement": {"pos_range": [[0.1, 0.05, 0.0], [0.1, 0.05, 0.0]], "yaw_range": [30, 30]},
            "orientations": [[90.0, 0.0, 0.0]],
        },
        robot_placement={"pos_range": [[0.0, -0.5, 0.0], [0.0, -0.5, 0.0]], "yaw_range": [90, 90]},
    )
    scene = Scene.build(task.robot, task.objects, task.physics)
    state = scene.reset(task, np.random.default_rng(0))
    assert state.T_world_root[:3, 3] == pytest.approx([0.0, -0.5, 0.0])
    T = scene.T_world_object("target")
    assert T[:2, 3] == pytest.approx([0.1, 0.05], abs=2e-3)
    # x 90 deg then yaw 30 deg: the object's z axis lies in the table plane.
    assert abs(T[2, 2]) < 0.02
    assert state.orientation_choice == 0


def test_arm_base_frame_faces_the_table(fr3_scene: tuple[Scene, TaskConfig]) -> None:
    """Arm base x points to +y (the table), z up; the object is in front (base x > 0)."""
    scene, task = fr3_scene
    scene.reset(task, np.random.default_rng(0))
    T_wb = scene.T_world_base("left")
    assert np.allclose(T_wb[:3, 0], [0, 1, 0], atol=1e-9)
    assert np.allclose(T_wb[:3, 2], [0, 0, 1], atol=1e-9)
    T_bo = invert_T(T_wb) @ scene.T_world_object("target")
    assert T_bo[0, 3] > 0.2
    assert np.allclose(scene.T_base_frame("left", "left_hand"), scene.T_base_ee("left"))


def test_robot_table_contact_switch(cube_mesh: Path) -> None:
    """With table contact off, an arm driven into the table passes through; on, it is stopped
    and the contact is reported as a robot-environment contact."""
    results = {}
    for contact in (False, True):
        task = make_task("fr3", "left", cube_mesh, physics={"table_contact": contact})
        scene = Scene.build(task.robot, task.objects, task.physics)
        scene.reset(task, np.random.default_rng(0))
        handles = scene.arms["left"]
        # Push the elbow down: joint 2 forward, the hand into the table.
        target = scene.data.qpos[handles.active_qpos].copy()
        target[1] += 1.2
        scene.data.ctrl[handles.active_actuators] = target
        seen: set[tuple[str, str]] = set()
        for _ in range(100):
            scene.step(10)
            seen.update(scene.robot_contacts("left"))
        tcp_z = scene.T_world_body(handles.tcp_body)[2, 3]
        results[contact] = (tcp_z, seen)
    assert results[False][0] < -0.02  # went through the table top
    assert not any(TABLE_NAME in pair[1] or pair[1] == "world" for pair in results[False][1])
    assert results[True][0] > -0.01  # stopped on the table
    assert any(pair[1] == "world" for pair in results[True][1])  # the table is a world geom


def test_finger_forces_per_finger_when_gripping(cube_mesh: Path) -> None:
    """Close the fingers on the cube placed between the pads: both fingers feel ~kp * w / 2."""
    task = make_task("fr3", "left", cube_mesh, physics={"gravity": [0.0, 0.0, 0.0]})
    scene = Scene.build(task.robot, task.objects, task.physics)
    scene.reset(task, np.random.default_rng(0), settle_time=0.0)
    handles = scene.arms["left"]
    mujoco.mj_forward(scene.model, scene.data)
    T_tcp = scene.T_world_body(handles.tcp_body)
    obj = scene.objects["target"]
    scene.data.qpos[obj.qpos_adr : obj.qpos_adr + 3] = T_tcp[:3, 3]
    scene.data.qpos[obj.qpos_adr + 3 : obj.qpos_adr + 7] = [1, 0, 0, 0]
    scene.data.qvel[:] = 0
    assert scene.finger_forces("left", "target") == (0.0, 0.0)
    scene.data.ctrl[handles.gripper_actuator] = 0.0
    scene.step(500)
    left, right = scene.finger_forces("left", "target")
    # One servo (kp 300 N/m) 2 cm short of its target squeezes with both coupled fingers.
    assert left > 2.0 and right > 2.0
    assert left == pytest.approx(right, rel=0.1)
    assert scene.gripper_opening("left") == pytest.approx(0.02, abs=2e-3)


def test_unstable_physics_is_detected(cube_mesh: Path) -> None:
    """A 50 ms explicit-Euler step with one solver iteration diverges; unstable() says so."""
    physics = {"timestep": 0.05, "integrator": "euler", "solver_iterations": 1}
    task = make_task("fr3", "left", cube_mesh, physics=physics, control_dt=0.05)
    scene = Scene.build(task.robot, task.objects, task.physics)
    scene.reset(task, np.random.default_rng(0), settle_time=0.0)
    assert scene.unstable() is None
    reason = None
    for _ in range(200):
        scene.step(1)
        reason = scene.unstable()
        if reason:
            break
    assert reason is not None and "diverged" in reason


def test_dual_arm_scene_has_both_arms_and_the_lift() -> None:
    scene = Scene.build("lift2", [], PhysicsConfig())
    assert set(scene.arms) == {"left", "right"}
    for handles in scene.arms.values():
        assert handles.active_names[0] == "lift_joint"
        assert len(handles.active_names) == 7


def test_object_contacts_use_the_average_friction() -> None:
    """Issue 16 item 4: object-pad and object-table contacts are explicit pairs whose friction is
    the average of the two coefficients (PhysX's default), so the object's friction matters."""
    from harness.config import apply_overrides, load_task
    from harness.sim.friction import combined_friction
    from harness.sim.scene import Scene

    assert combined_friction((0.1, 0.005, 0.0001), (1.5, 0.01, 0.0001)) == pytest.approx(
        [0.8, 0.8, 0.0075, 0.0001, 0.0001]
    )
    task = apply_overrides(
        load_task(Path(__file__).resolve().parents[1] / "tasks" / "pick" / "fr3.yaml"),
        {"object.friction": 0.2},
    )
    scene = Scene.build(task.robot, task.objects, task.physics, task.base_dir())
    model = scene.model
    names = [
        (model.geom(a).name, model.geom(b).name)
        for a, b in zip(model.pair_geom1, model.pair_geom2, strict=True)
    ]
    pieces = {b for _, b in names}
    assert pieces and all(name.startswith("cube_piece") for name in pieces)
    for (first, _), friction in zip(names, model.pair_friction, strict=True):
        other = 1.0  # the table's and the FR3 pads' sliding friction
        assert first == "table" or "finger" in first or "_pad" in first or "_col" in first
        assert friction[0] == pytest.approx((0.2 + other) / 2)
        # torsion: the table pair averages MuJoCo's default 0.005; an object-pad pair takes the
        # FR3 pad patch's 0.00515 m (robots/fr3/robot.yaml) at the pair's sliding friction
        torsion = 0.005 if first == "table" else 0.00515 * (0.2 + other) / 2 / other
        assert friction[2] == pytest.approx(torsion)
