"""The robots' own conventions (robot.yaml) tie them to the grasp core: the canonical reference
filters of fr3, lift2 and split_aloha select the same physical grasps (docs/reference-pick-skill.md
section 11)."""

from __future__ import annotations

import numpy as np
from helpers import canonical_filters
from reference_robots import REFERENCE_ROBOTS

from harness.config import PickConfig
from harness.grasps import CandidateRule, ee_poses_for_pick, load_grasp_file, select_candidates
from harness.pick.semantics import Semantics
from harness.robots import RobotModel
from harness.transforms import make_T, yaw_matrix

CANONICAL = {name: canonical_filters(name) for name in REFERENCE_ROBOTS}


def rule_of(pick: PickConfig) -> CandidateRule:
    """The candidate rule of the pick's semantics."""
    return Semantics.from_pick(pick).candidates


def test_canonical_filters_select_the_same_grasps_with_robot_yaml_axes(example_objects):
    robots = {name: RobotModel.load(name) for name in CANONICAL}
    rng = np.random.default_rng(7)
    for folder in example_objects:
        grasps = load_grasp_file(folder / "Aligned_grasp_sparse.npy")
        for _ in range(6):
            yaw = rng.uniform(-np.pi, np.pi)
            position = [rng.uniform(0.3, 0.6), rng.uniform(-0.2, 0.2), rng.uniform(-0.1, 0.1)]
            T_base_obj = make_T(yaw_matrix(yaw), position)
            masks, orders = {}, {}
            for name, robot in robots.items():
                pick = PickConfig(**CANONICAL[name])
                poses = ee_poses_for_pick(grasps, robot.convention, pick)
                selection = select_candidates(
                    poses,
                    robot.convention,
                    pick,
                    T_base_obj,
                    np.random.default_rng(11),
                    rule_of(pick),
                )
                masks[name] = selection.filter_result.combined
                orders[name] = selection.order.indices
            assert masks["fr3"].any(), folder
            np.testing.assert_array_equal(masks["fr3"], masks["lift2"])
            np.testing.assert_array_equal(masks["fr3"], masks["split_aloha"])
            np.testing.assert_array_equal(orders["fr3"], orders["lift2"])
            np.testing.assert_array_equal(orders["fr3"], orders["split_aloha"])


def test_neutral_filters_equal_each_robots_canonical_set(example_objects):
    grasps = load_grasp_file(example_objects[0] / "Aligned_grasp_sparse.npy")
    neutral = PickConfig(approach_filter=["downward", 140], facing_filter=["forward", 90])
    T_base_obj = make_T(yaw_matrix(0.7), [0.45, 0.05, 0.0])
    for name, filters in CANONICAL.items():
        robot = RobotModel.load(name)
        canonical = PickConfig(**filters)
        a = select_candidates(
            ee_poses_for_pick(grasps, robot.convention, canonical),
            robot.convention,
            canonical,
            T_base_obj,
            np.random.default_rng(0),
            rule_of(canonical),
        )
        b = select_candidates(
            ee_poses_for_pick(grasps, robot.convention, neutral),
            robot.convention,
            neutral,
            T_base_obj,
            np.random.default_rng(0),
            rule_of(neutral),
        )
        np.testing.assert_array_equal(a.filter_result.combined, b.filter_result.combined)
