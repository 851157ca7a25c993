"""Helpers shared by the test modules (test modules import this, never each other).

- the robot lists, from the registry (``harness.config.robot_registry``): a new robot folder
  and its task file are picked up without editing a test;
- synthetic objects with grasps (a box mesh and its antipodal grasp file) and a canonical pick
  task on one (:func:`make_task`), so the pick tests do not depend on the default object set;
- a scene with its planner, and a top-down grasp pose, for the planning tests;
- the installed ``harness`` console script run as a user runs it;
"""

from __future__ import annotations

import functools
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh
import yaml
from hypothesis import strategies as st

from harness.config import TaskConfig
from harness.config.robot_registry import available_robots, canonical_task_files
from harness.robots.facts import interndata_robots, robot_arms

PROJECT_ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = PROJECT_ROOT / "tasks" / "examples"

# The InternDataEngine example data (objects, grasp files, task and robot YAMLs of the public
# reference; CC BY-NC-SA 4.0, so not in this repository): PICK_HARNESS_EXAMPLES, else
# ../shared/datasets/interndata-examples beside the repository. docs/interndata.md, "Example
# data", says where it comes from.
INTERNDATA_EXAMPLES_ENV = "PICK_HARNESS_EXAMPLES"
INTERNDATA_EXAMPLES = Path(
    os.environ.get(INTERNDATA_EXAMPLES_ENV)
    or PROJECT_ROOT.parent / "shared" / "datasets" / "interndata-examples"
)
NO_INTERNDATA_EXAMPLES = (
    f"InternDataEngine example data not found at {INTERNDATA_EXAMPLES}: set "
    f"{INTERNDATA_EXAMPLES_ENV}=DIR (where to get it: docs/interndata.md#example-data)"
)
HARNESS = Path(sys.executable).with_name("harness")
TASKS_DIR = PROJECT_ROOT / "tasks" / "pick"
"""The canonical pick task files (``tasks/pick/<robot>[_<arm>].yaml``)."""


def episode(task: TaskConfig, seed: int = 0, cache: dict | None = None, **spec: Any) -> Any:
    """``run_episode`` of ``task`` at ``seed`` (``cache``: a scene cache; ``spec``: more
    ``EpisodeSpec`` fields)."""
    from harness.episode import EpisodeSpec, run_episode

    return run_episode(EpisodeSpec(task=task, seed=seed, **spec), cache)


# --------------------------------------------------------------------------------------------
# Robot lists (the registry's)

ROBOTS = available_robots()
"""Every bundled robot (a folder of robots/ with a robot.yaml), sorted."""

ROBOT_ARMS = [(name, arm) for name in ROBOTS for arm in robot_arms(name)]
"""Every (robot, arm) of the bundled robots."""

PICK_TASKS = [path.stem for name in ROBOTS for path in canonical_task_files(name)]
"""Stems of every canonical pick task file (``tasks/pick/<robot>[_<arm>].yaml``)."""

AVAILABLE_ROBOTS_TEXT = ", ".join(ROBOTS)
"""How error messages list the bundled robots (``unknown robot ...; available robots: ...``)."""

INTERNDATA_ROBOTS_TEXT = ", ".join(interndata_robots().values())
"""How error messages list the robots an InternDataEngine task may name (``supported: ...``)."""

FILTER_KEYS = ("filter_x_dir", "filter_y_dir", "filter_z_dir")

CANONICAL_PICK = {
    "pre_grasp_offset": 0.05,
    "post_grasp_offset_min": 0.05,
    "post_grasp_offset_max": 0.20,
    "lift_th": 0.02,
    "gripper_change_steps": 10,
    "t_eps": 0.01,
    "o_eps": 1,
    "process_valid": True,
}


@functools.cache
def canonical_robot_pick(robot: str) -> dict[str, Any]:
    """The direction filters and ``test_mode`` of the robot's first canonical task file (the
    reference's canonical filters for its convention, docs/reference-pick-skill.md section 9)."""
    pick = yaml.safe_load(canonical_task_files(robot)[0].read_text(encoding="utf-8"))["pick"]
    return {key: pick[key] for key in (*FILTER_KEYS, "test_mode") if key in pick}


def canonical_filters(robot: str) -> dict[str, Any]:
    """The direction filters alone of the robot's canonical task (``filter_<axis>_dir``)."""
    return {k: v for k, v in canonical_robot_pick(robot).items() if k in FILTER_KEYS}


# --------------------------------------------------------------------------------------------
# Synthetic objects with grasps


def box_grasps(half_width: float, half_height: float, score_tilt: float = 0.2) -> np.ndarray:
    """Antipodal grasps of a box centred at the origin: closing across x or y faces, approach
    tilted -90..90 deg (15 deg steps) from straight down about the closing axis, TCP at the
    centre (depth 0.01 and 0.02). GraspNet layout (N x 17), float32."""
    rows = []
    for closing in (np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])):
        perpendicular = np.cross(closing, [0.0, 0.0, 1.0])
        for tilt in np.deg2rad(np.arange(-90, 91, 15)):
            g_x = np.cos(tilt) * np.array([0.0, 0.0, -1.0]) + np.sin(tilt) * perpendicular
            g_z = np.cross(g_x, closing)
            R = np.stack([g_x, closing, g_z], axis=1)
            for depth in (0.01, 0.02):
                row = np.zeros(17)
                row[0] = 0.1 if abs(tilt) < 0.8 else score_tilt
                row[1] = 2 * half_width
                row[2] = 0.02
                row[3] = depth
                row[4:13] = R.reshape(-1)
                row[13:16] = -g_x * depth
                row[16] = -1
                rows.append(row)
    del half_height
    return np.asarray(rows, dtype=np.float32)


def write_box(folder: Path, extents: tuple[float, float, float], name: str = "box") -> Path:
    """A box mesh (OBJ) with its grasp file (``grasps.npy``) in ``folder``; returns the mesh."""
    folder.mkdir(parents=True, exist_ok=True)
    mesh_path = folder / f"{name}.obj"
    trimesh.creation.box(extents=extents).export(mesh_path)
    np.save(folder / "grasps.npy", box_grasps(extents[0] / 2, extents[2] / 2))
    return mesh_path


def make_task(
    robot: str,
    arm: str,
    mesh: Path,
    pick: dict[str, Any] | None = None,
    **task: Any,
) -> TaskConfig:
    """A canonical pick task (docs/reference-pick-skill.md section 9) of ``robot``/``arm`` on
    ``mesh``: the robot's canonical filters and test mode, the reference's pick values."""
    obj = {"name": "target", "mesh": str(mesh), **task.pop("object", {})}
    data = {
        "name": f"{robot}_{arm}_test",
        "robot": robot,
        "arm": arm,
        "objects": [obj, *task.pop("extra_objects", [])],
        "physics": {"table_contact": False, **task.pop("physics", {})},
        "pick": {**canonical_robot_pick(robot), **CANONICAL_PICK, **(pick or {})},
        **task,
    }
    return TaskConfig.model_validate(data)


# --------------------------------------------------------------------------------------------
# Planning


def scene_planner(task: TaskConfig) -> tuple[Any, Any]:
    """The task's scene (reset with seed 0) and its arm's ``PickPlanner``."""
    from harness.episode.scene_cache import get_scene

    bundle = get_scene(task, {})
    scene = bundle.scene
    scene.reset(task, np.random.default_rng(0))
    planner = bundle.planner(task.arm)
    return scene, planner


def top_down_grasp(scene: Any, arm: str, obj: str = "target") -> np.ndarray:
    """A world EE pose grasping the object from straight above (FR3 convention: z down)."""
    T_obj = scene.T_world_object(obj)
    T = np.eye(4)
    T[:3, :3] = np.diag([1.0, -1.0, -1.0])
    T_base = scene.T_world_base(arm)
    T[:3, :3] = T_base[:3, :3] @ T[:3, :3]
    T[:3, 3] = T_obj[:3, 3] + [0.0, 0.0, scene.robot.convention.tcp_offset]
    return T


# --------------------------------------------------------------------------------------------
# The command line


def harness(*args: str | Path, cwd: Path = PROJECT_ROOT) -> subprocess.CompletedProcess[str]:
    """The installed ``harness`` console script in a subprocess (skips when not installed)."""
    if not HARNESS.exists():
        pytest.skip(f"console script {HARNESS} is not installed (pip install -e .)")
    return subprocess.run(
        [str(HARNESS), *map(str, args)],
        cwd=cwd,
        capture_output=True,
        text=True,
        stdin=subprocess.DEVNULL,
        timeout=120,
        check=False,
    )


# --------------------------------------------------------------------------------------------
# Rerun recordings read back with Rerun's own reader (test_recording, test_cause)

FAR = {"placement": {"pos_range": [[0.75, 0.3, 0.0], [0.75, 0.3, 0.0]]}}  # 1.07 m from the FR3


def read_back(path: Path) -> tuple[dict[str, dict[str, int]], dict[str, list]]:
    """Per entity, the rows of each component; and the values of the text-like components."""
    from rerun.chunk import RrdReader

    rows: dict[str, dict[str, int]] = {}
    values: dict[str, list] = {}
    for chunk in RrdReader(str(path)).stream().to_chunks():
        batch = chunk.to_record_batch()
        counts = rows.setdefault(chunk.entity_path, {})
        for name in batch.schema.names:
            if ":" not in name:
                continue  # an index or row id column
            counts[name] = counts.get(name, 0) + chunk.num_rows
            if name.endswith((":text", ":labels")):
                values.setdefault(f"{chunk.entity_path}#{name}", []).extend(
                    batch.column(name).to_pylist()
                )
    return rows, values


def blueprint_views(path: Path) -> dict[str, str]:
    """The recording's blueprint: view origin -> view class."""
    from rerun.chunk import RrdReader

    reader = RrdReader(str(path))
    views: dict[str, str] = {}
    for chunk in reader.stream(store=reader.blueprints()[0]).to_chunks():
        batch = chunk.to_record_batch()
        if "ViewBlueprint:space_origin" in batch.schema.names:
            origin = batch.column("ViewBlueprint:space_origin").to_pylist()[0][0]
            kind = batch.column("ViewBlueprint:class_identifier").to_pylist()[0][0]
            views[origin] = kind
    return views


def body_entities(rows: dict[str, dict[str, int]]) -> set[str]:
    """The ``/world/bodies/<body>`` entities that carry geometry."""
    return {
        path.rsplit("/", 1)[0]
        for path in rows
        if path.startswith("/world/bodies/") and path.rsplit("/", 1)[1].startswith("geom")
    }


def flatten(values: list) -> list[str]:
    out: list[str] = []
    for value in values:
        out.extend(flatten(value) if isinstance(value, list) else [str(value)])
    return out


# The reference's Split ALOHA handover (InternDataEngine c4fa389,
# workflows/simbox/core/configs/tasks/long_horizon/split_aloha/handover/lr/bowl.yaml): its robot
# and pick-object regions (67-98), the left pick (158-168), the left goto__pose (170-181) and
# the right pick (185-195). The task after them (grippers, place) does not change these picks.
HANDOVER_ROBOT_REGION = [[0.0, -0.86, -0.74], [0.0, -0.86, -0.74]]
HANDOVER_OBJECT_REGION = [[-0.5, -0.2, 0.0], [-0.1, 0.2, 0.0]]
HANDOVER_FIRST_PICK: dict[str, Any] = {
    "name": "pick",
    "filter_y_dir": ["forward", 90],
    "filter_z_dir": ["downward", 160],
    "t_eps": 0.01,
    "o_eps": 1,
    "close_wait_steps": 10,
    "post_grasp_offset_min": 0.1,
    "post_grasp_offset_max": 0.1,
    "constraints": ["y", 0.2, 0.3],
}
HANDOVER_GOTO: dict[str, Any] = {
    "name": "goto__pose",
    "position_constraint": "object",
    "gripper_state": -1,
    "position": [0.3, -0.25, 0.1],
    "align_obj_axis": [0, 1, 0],
    "align_ref_axis": [0, 0, 1],
    "align_obj_tol": 30,
    "filter_x_dir": ["forward", 70],
    "max_noise_m": 0.05,
    "max_noise_deg": 5,
    "interp_nums": 1,
}
HANDOVER_SECOND_PICK: dict[str, Any] = {
    "name": "pick",
    "filter_y_dir": ["upward", 40],
    "filter_x_dir": ["backward", 110],
    "pre_grasp_offset": 0.1,
    "close_wait_steps": 10,
    "t_eps": 0.01,
    "o_eps": 1,
    "post_grasp_offset_min": 0.0,
    "post_grasp_offset_max": 0.0,
    "constraints": ["y", 0.65, 0.9],
}


def write_handover_file(examples: Path, folder: Path) -> Path:
    """The example Split ALOHA single-pick file turned into the reference's handover: its
    regions, and the skills left pick, left goto__pose, then right pick of the same object."""
    source = examples / "tasks" / "split_aloha_left_single_pick_banana.yaml"
    data = yaml.safe_load(source.read_text(encoding="utf-8"))
    task = data["tasks"][0]
    task.pop("distractors", None)
    for region in task["regions"]:
        is_robot = region["object"] == "split_aloha"
        region["random_config"]["pos_range"] = (
            HANDOVER_ROBOT_REGION if is_robot else HANDOVER_OBJECT_REGION
        )
        region["random_config"]["yaw_rotation"] = [0.0, 0.0]
    target = {"objects": ["pick_object_left"]}
    task["skills"] = [
        {
            "split_aloha": [
                {"left": [HANDOVER_FIRST_PICK | target, HANDOVER_GOTO | target]},
                {"right": [HANDOVER_SECOND_PICK | target]},
            ]
        }
    ]
    path = folder / "split_aloha_handover.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return path


# A tug rung's outcome as the judge makes it (survived, slip in m, between the fingers):
# survived only when still between the fingers (tests/test_validity.py).
rung_outcomes = st.builds(
    lambda survived, slip, between: (survived and between, slip, between or survived),
    st.booleans(),
    st.floats(0.0, 0.05),
    st.booleans(),
)
