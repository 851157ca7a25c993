"""The per-worker scene cache: a built scene with its IK solvers, planners and grasp poses.

Building a MuJoCo scene, an IK model and a planner costs far more than an episode on them, so a
worker keeps them in ``scene_cache`` (any dict), keyed by (robot and gripper, objects, physics):
an episode on a cached scene only resets arrays. The grasp files and their post-processed EE
poses are cached with the scene that uses them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from harness.config import TaskConfig
from harness.errors import HarnessError
from harness.grasps import EEPoses, GraspSet, load_grasp_file, post_process
from harness.objects.assets import find_grasp_file
from harness.planning.arm_ik import arm_ik
from harness.planning.ik import WholeBodyIK
from harness.planning.planner import PickPlanner
from harness.sim import Scene, scene_key


@dataclass
class SceneBundle:
    """A scene with its per-arm IK solvers and planners and the grasp poses it has used."""

    scene: Scene
    iks: dict[str, WholeBodyIK] = field(default_factory=dict)
    planners: dict[str, PickPlanner] = field(default_factory=dict)
    grasp_sets: dict[str, GraspSet] = field(default_factory=dict)
    ee_poses: dict[tuple[Any, ...], EEPoses] = field(default_factory=dict)
    # Which reset the scene holds untouched (``harness.episode.setup.Setup.ensure_fresh``): lets an
    # episode that shares a seed's evaluations skip a reset it would only repeat.
    reset_mark: Any = None

    def planner(self, arm: str) -> PickPlanner:
        if arm not in self.planners:
            ik, _ = arm_ik(self.scene.robot, arm)
            assert ik.joint_names == self.scene.arms[arm].active_names, "one active-joint order"
            self.iks[arm] = ik
            self.planners[arm] = PickPlanner(self.scene, arm, ik)
        return self.planners[arm]

    def poses(self, task: TaskConfig, grasp_path: str) -> EEPoses:
        pick = task.pick
        key = (grasp_path, pick.grasp_scale, pick.tcp_offset, pick.constraints)
        if key not in self.ee_poses:
            if grasp_path not in self.grasp_sets:
                self.grasp_sets[grasp_path] = load_grasp_file(grasp_path)
            self.ee_poses[key] = post_process(
                self.grasp_sets[grasp_path],
                self.scene.robot.convention,
                pick.grasp_scale,
                pick.tcp_offset,
                pick.constraints,
            )
        return self.ee_poses[key]


def get_scene(task: TaskConfig, scene_cache: dict[Any, Any] | None) -> SceneBundle:
    """The scene for ``task``, built once per (robot, objects, physics) in ``scene_cache``."""
    key = scene_key(task)
    if scene_cache is not None and key in scene_cache:
        return scene_cache[key]
    bundle = SceneBundle(Scene.for_task(task))
    if scene_cache is not None:
        scene_cache[key] = bundle
    return bundle


def grasp_file_for(task: TaskConfig, scene: Scene) -> str:
    """The target object's grasp file: ``grasps`` if given, else the naming rule."""
    obj = task.target_object
    asset = scene.objects[obj.name].asset
    if obj.grasps:
        path = asset.grasp_path
    elif task.pick.npy_name != "Aligned_grasp_sparse.npy":
        path = find_grasp_file(asset.path, task.pick.npy_name)
    else:
        path = asset.grasp_path
    if path is None:
        raise HarnessError(
            f"object {obj.name!r} ({asset.path}) has no grasp file "
            f"({task.pick.npy_name} or <mesh>_grasps.npy or grasps.npy next to the mesh)"
        )
    return str(path)
