"""Grasp core against the reference semantics (docs/reference-pick-skill.md sections 2-4, 11).

Hand-computed cases for post-processing, every filter direction / sign / form, direction_to_obj,
the neutral filters, and the candidate order; then the shared example grasp files.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from helpers import canonical_filters
from pydantic import ValidationError
from reference_robots import EE_AXES_IN_GRASPNET, REFERENCE_ROBOTS
from scipy.spatial.transform import Rotation
from scipy.stats import chisquare

from harness.config import AxisFilter, ConfigError, PickConfig
from harness.errors import InputFileError
from harness.grasps import (
    CandidateRule,
    GraspSet,
    base_frame_poses,
    check_strict_filters,
    filter_ee_poses,
    filter_poses,
    load_grasp_file,
    neutral_form,
    post_process,
    reference_order,
    resolve_filters,
    select_candidates,
    strict_order,
    top_by_score,
)
from harness.pick.semantics import Semantics
from harness.robots.facts import reference_convention
from harness.transforms import make_T, yaw_matrix

# The grasp tests pin the reference's hand math, so they run on the reference robots. Each
# robot's grasp convention from its robots/<name>/robot.yaml (test_robot.py checks those values
# against the reference robot configs).
ROBOTS = REFERENCE_ROBOTS
REFERENCE_CONVENTIONS = {robot: reference_convention(robot) for robot in ROBOTS}


def rule_of(pick: PickConfig) -> CandidateRule:
    """The candidate rule of the pick's semantics."""
    return Semantics.from_pick(pick).candidates


def rng0() -> np.random.Generator:
    return np.random.default_rng(0)


def grasp_row(
    R_g: np.ndarray,
    point: tuple[float, float, float] = (0.0, 0.0, 0.0),
    score: float = 0.1,
    width: float = 0.05,
    depth: float = 0.02,
) -> np.ndarray:
    """One N x 17 row: score, width, height, depth, R_g row-major, point, object id."""
    return np.concatenate([[score, width, 0.02, depth], np.ravel(R_g), point, [-1.0]])


def spec(*values: object) -> AxisFilter:
    direction, *angles = values
    return AxisFilter(direction=direction, angles=tuple(float(a) for a in angles))


# Grasp axes of a top-down grasp: approach g_x = -Z, closing g_y = +X, g_z = g_x x g_y = -Y.
G_X, G_Y, G_Z = np.array([0.0, 0, -1]), np.array([1.0, 0, 0]), np.array([0.0, -1, 0])
R_TOP_DOWN = np.column_stack([G_X, G_Y, G_Z])


# --------------------------------------------------------------------------------------------
# Post-processing (section 3)

# EE axes (x, y, z) of the top-down grasp per robot, from the table "EE axes in GraspNet terms"
# and, for the flipped copy, the same turned 180 degrees about the approach axis.
AXIS_OF = {"x": G_X, "y": G_Y, "z": G_Z}


def graspnet_axes(names: tuple[str, ...]) -> list[np.ndarray]:
    """``("-z", "y", "x")`` -> [-G_Z, G_Y, G_X]."""
    return [-AXIS_OF[n[1]] if n.startswith("-") else AXIS_OF[n] for n in names]


@pytest.mark.parametrize("robot", ROBOTS)
def test_post_process_hand_math_top_down(robot: str) -> None:
    convention = REFERENCE_CONVENTIONS[robot]
    grasps = GraspSet.from_array(
        np.stack([grasp_row(R_TOP_DOWN, (0.01, 0.02, 0.03), score=0.2, width=0.095, depth=0.02)])
    )
    poses = post_process(grasps, convention)
    assert len(poses) == 2 and poses.n_grasps == 1
    unflipped, flipped = (graspnet_axes(a) for a in EE_AXES_IN_GRASPNET[robot])
    np.testing.assert_array_equal(poses.rotations[0], np.column_stack(unflipped))
    np.testing.assert_array_equal(poses.rotations[1], np.column_stack(flipped))
    # The EE origin sits tcp_offset - depth behind the grasp point along the approach (-Z), i.e.
    # above it; both copies share it.
    behind = convention.tcp_offset - 0.02
    np.testing.assert_allclose(poses.positions, [[0.01, 0.02, 0.03 + behind]] * 2, atol=1e-15)
    np.testing.assert_array_equal(poses.scores, [0.2, 0.2])
    np.testing.assert_array_equal(poses.source_row, [0, 0])
    np.testing.assert_array_equal(poses.flipped, [False, True])
    np.testing.assert_allclose(poses.tcp_points, [[0.01, 0.02, 0.03]] * 2)
    expected_width = min(0.095, convention.gripper_max_width)
    np.testing.assert_allclose(poses.widths, [expected_width] * 2)
    np.testing.assert_allclose(poses.approach_axes, [G_X, G_X])


@pytest.mark.parametrize("robot", ROBOTS)
def test_post_process_general_rotation_rows_of_R_ee_graspnet(robot: str) -> None:
    convention = REFERENCE_CONVENTIONS[robot]
    R_g = np.array(
        [[0.36, 0.48, -0.8], [-0.8, 0.6, 0.0], [0.48, 0.64, 0.6]]
    )  # a proper rotation with exact decimal entries
    assert np.linalg.det(R_g) == pytest.approx(1.0)
    point = np.array([0.05, -0.02, 0.1])
    grasps = GraspSet.from_array(np.stack([grasp_row(R_TOP_DOWN), grasp_row(R_g, point)]))
    poses = post_process(grasps, convention, grasp_scale=0.5, tcp_offset=0.13)
    assert len(poses) == 4
    R = poses.rotations[1]
    for j in range(3):  # EE axis j = R_g @ (row j of R_ee_graspnet)
        np.testing.assert_allclose(R[:, j], R_g @ convention.R_ee_graspnet[j], atol=1e-15)
    a = R[:, convention.approach_index]
    np.testing.assert_allclose(a, R_g[:, 0])  # the approach is g_x for every robot
    # Scaled point, unscaled depth, the overridden tcp_offset.
    np.testing.assert_allclose(poses.positions[1], 0.5 * point + a * (0.02 - 0.13), atol=1e-15)
    np.testing.assert_allclose(poses.positions[3], poses.positions[1])
    flip = np.diag(np.where(np.arange(3) == convention.approach_index, 1.0, -1.0))
    np.testing.assert_allclose(poses.rotations[3], R @ flip)
    np.testing.assert_array_equal(poses.source_row, [0, 1, 0, 1])
    # Lazily derived arrays agree with per-index access.
    np.testing.assert_array_equal(poses.rotations_at(np.arange(4)), poses.rotations)
    np.testing.assert_array_equal(poses.T_obj_ee_at([3, 0]), poses.T_obj_ee[[3, 0]])


def test_constraints_act_on_scaled_tcp_before_flipping() -> None:
    rows = [
        grasp_row(R_TOP_DOWN, (0.0, y, 0.0), score=0.1 + 0.1 * i)
        for i, y in enumerate([0.0, 0.1, 0.2, 0.3, 0.4])
    ]
    grasps = GraspSet.from_array(np.stack(rows))
    convention = REFERENCE_CONVENTIONS["fr3"]
    # Scaled y = [0, .2, .4, .6, .8]; keep 0.2..0.6 of the range: [0.16, 0.48] -> rows 1, 2.
    poses = post_process(grasps, convention, grasp_scale=2.0, constraints=("y", 0.2, 0.6))
    assert poses.n_grasps == 2
    np.testing.assert_array_equal(poses.source_row, [1, 2, 1, 2])
    np.testing.assert_allclose(poses.scores, [0.2, 0.3, 0.2, 0.3])
    np.testing.assert_allclose(poses.tcp_points[:, 1], [0.2, 0.4, 0.2, 0.4])
    np.testing.assert_array_equal(poses.flipped, [False, False, True, True])
    # Bounds are inclusive: the full range keeps everything, [0, 0] keeps the minimum only.
    assert post_process(grasps, convention, constraints=("y", 0.0, 1.0)).n_grasps == 5
    np.testing.assert_array_equal(
        post_process(grasps, convention, constraints=("y", 0.0, 0.0)).source_row, [0, 0]
    )


# --------------------------------------------------------------------------------------------
# Direction filters (section 4.2), hand-computed

# Unit vectors at these angles from +X (in the x-z plane) or from +Z (in the z-x plane). 90 is
# exactly perpendicular (component exactly 0.0).
ANGLES = (0, 30, 60, 89, 90, 91, 120, 150, 180)


def _unit(angle_deg: float, from_axis: str) -> np.ndarray:
    if angle_deg == 90:
        along, across = 0.0, 1.0
    else:
        along, across = np.cos(np.deg2rad(angle_deg)), np.sin(np.deg2rad(angle_deg))
    if from_axis == "x":
        return np.array([along, 0.0, across])
    return np.array([across, 0.0, along])


def _rotation_with_column(column: int, v: np.ndarray) -> np.ndarray:
    """A proper rotation whose ``column`` is ``v``."""
    helper = np.array([0.0, 1.0, 0.0]) if abs(v[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    a = np.cross(v, helper)
    a /= np.linalg.norm(a)
    b = np.cross(v, a)
    cols = [None, None, None]
    cols[column], cols[(column + 1) % 3], cols[(column + 2) % 3] = v, a, b
    R = np.column_stack(cols)
    assert np.linalg.det(R) == pytest.approx(1.0)
    return R


def _poses_with_axis(column: int, from_axis: str) -> np.ndarray:
    return make_T(
        np.stack([_rotation_with_column(column, _unit(a, from_axis)) for a in ANGLES]),
        np.zeros(3),
    )


T, F = True, False
# (filter, expected keep per angle in ANGLES), worked out by hand from "theta is measured from
# base +X (forward/backward) or +Z (upward/downward)".
FILTER_CASES = [
    (("forward", 45), [T, T, F, F, F, F, F, F, F]),
    (("forward", 90), [T, T, T, T, F, F, F, F, F]),  # exact perpendicular rejected
    (("forward", 135), [T, T, T, T, T, T, T, F, F]),
    (("backward", 45), [F, F, T, T, T, T, T, T, T]),
    (("backward", 90), [F, F, F, F, T, T, T, T, T]),  # 0.0 <= cos(90) = 6.1e-17 keeps it
    (("backward", 135), [F, F, F, F, F, F, F, T, T]),
    (("forward", 135, 45), [F, F, T, T, T, T, T, F, F]),  # 45..135 degrees from +X
    (("backward", 45, 135), [F, F, T, T, T, T, T, F, F]),
    (("forward", 45, 135), [F] * 9),  # reversed order: silently empty
    (("backward", 135, 45), [F] * 9),
    (("upward", 40), [T, T, F, F, F, F, F, F, F]),
    (("upward", 90), [T, T, T, T, F, F, F, F, F]),
    (("downward", 140), [F, F, F, F, F, F, F, T, T]),  # within 40 degrees of -Z
    (("downward", 90), [F, F, F, F, T, T, T, T, T]),
    (("upward", 125, 55), [F, F, T, T, T, T, T, F, F]),
    (("downward", 110, 140), [F, F, F, F, F, F, T, F, F]),  # 110..140 from +Z
    (("downward", 55, 125), [F, F, T, T, T, T, T, F, F]),
    (("upward", 55, 125), [F] * 9),
    (("downward", 140, 110), [F] * 9),
]


@pytest.mark.parametrize("axis", ["x", "y", "z"])
@pytest.mark.parametrize(("values", "expected"), FILTER_CASES)
def test_direction_filter_hand_cases(axis: str, values: tuple, expected: list[bool]) -> None:
    column = "xyz".index(axis)
    from_axis = "x" if values[0] in ("forward", "backward") else "z"
    T_base_ee = _poses_with_axis(column, from_axis)
    key = f"filter_{axis}_dir"
    result = filter_poses(T_base_ee, {key: spec(*values)})
    np.testing.assert_array_equal(result.masks[key], expected)
    np.testing.assert_array_equal(result.combined, expected)
    assert result.counts() == {key: sum(expected)}
    assert spec(*values).never_passes() == (len(values) == 3 and not any(expected))


def test_filters_read_only_their_own_axis() -> None:
    # EE z points forward, EE x up: a z-forward filter passes, an x-forward filter does not.
    R = np.column_stack([[0.0, 0, 1], [0.0, -1, 0], [1.0, 0, 0]])
    T_base_ee = make_T(R[None], np.zeros(3))
    assert filter_poses(T_base_ee, {"filter_z_dir": spec("forward", 10)}).passed == 1
    assert filter_poses(T_base_ee, {"filter_x_dir": spec("forward", 80)}).passed == 0
    assert filter_poses(T_base_ee, {"filter_x_dir": spec("upward", 10)}).passed == 1
    assert filter_poses(T_base_ee, {"filter_y_dir": spec("downward", 170)}).passed == 0
    # A bare axis letter works as a key too; masks always carry the config key name.
    assert filter_poses(T_base_ee, {"z": spec("forward", 10)}).counts() == {"filter_z_dir": 1}
    # No filter: everything passes (the reference's all-ones flags).
    assert filter_poses(T_base_ee, {}).combined.tolist() == [True]


def test_direction_to_obj_both_sides() -> None:
    T_base_obj = make_T(np.eye(3), [0.4, 0.2, 0.0])
    T_base_ee = make_T(np.eye(3), [[0.4, 0.1, 0.3], [0.4, 0.2, 0.3], [0.4, 0.3, 0.3]])
    right = filter_poses(T_base_ee, {}, "right", T_base_obj)
    left = filter_poses(T_base_ee, {}, "left", T_base_obj)
    # "right" keeps EE y <= object y (base -Y side), "left" keeps y > object y.
    np.testing.assert_array_equal(right.masks["direction_to_obj"], [T, T, F])
    np.testing.assert_array_equal(left.masks["direction_to_obj"], [F, F, T])
    with pytest.raises(ValueError, match="direction_to_obj"):
        filter_poses(T_base_ee, {}, "up", T_base_obj)


def test_masks_are_anded_and_reported_individually() -> None:
    convention = REFERENCE_CONVENTIONS["fr3"]
    tilted = _rotation_with_column(0, _unit(60, "z"))  # g_x 60 degrees from +Z
    grasps = GraspSet.from_array(
        np.stack(
            [
                grasp_row(R_TOP_DOWN, (0.0, -0.05, 0.0)),
                grasp_row(R_TOP_DOWN, (0.0, 0.05, 0.0)),
                grasp_row(tilted, (0.0, 0.05, 0.0)),
            ]
        )
    )
    poses = post_process(grasps, convention)
    T_base_obj = make_T(np.eye(3), [0.5, 0.0, 0.0])
    filters = {"filter_z_dir": spec("downward", 140)}
    result = filter_ee_poses(poses, T_base_obj, filters, "left")
    np.testing.assert_array_equal(result.masks["filter_z_dir"], [T, T, F, T, T, F])
    np.testing.assert_array_equal(result.masks["direction_to_obj"], [F, T, T, F, T, T])
    np.testing.assert_array_equal(result.combined, [F, T, F, F, T, F])
    np.testing.assert_array_equal(result.passing_indices, [1, 4])


# --------------------------------------------------------------------------------------------
# Neutral filters


@pytest.mark.parametrize("robot", ROBOTS)
def test_canonical_filters_translate_to_one_neutral_pair(robot: str) -> None:
    convention = REFERENCE_CONVENTIONS[robot]
    pick = PickConfig(**canonical_filters(robot))
    neutral = neutral_form(pick.axis_filters(), convention)
    assert neutral == {
        "approach_filter": spec("downward", 140),
        "facing_filter": spec("forward", 90),
    }
    # And back: the neutral pair resolves to this robot's canonical per-axis filters.
    back = resolve_filters(
        PickConfig(approach_filter=["downward", 140], facing_filter=["forward", 90]), convention
    )
    assert back == PickConfig(**canonical_filters(robot)).axis_filters()


def test_resolve_filters_merges_and_rejects_clashes() -> None:
    fr3, lift2 = REFERENCE_CONVENTIONS["fr3"], REFERENCE_CONVENTIONS["lift2"]
    pick = PickConfig(approach_filter=["downward", 150], filter_y_dir=["upward", 100])
    assert resolve_filters(pick, fr3) == {
        "filter_y_dir": spec("upward", 100),
        "filter_z_dir": spec("downward", 150),
    }
    assert resolve_filters(pick, lift2) == {
        "filter_x_dir": spec("downward", 150),
        "filter_y_dir": spec("upward", 100),
    }
    clash = PickConfig(approach_filter=["downward", 150], filter_z_dir=["downward", 140])
    with pytest.raises(ConfigError, match=r"approach_filter.*EE z.*filter_z_dir"):
        resolve_filters(clash, fr3)
    assert resolve_filters(clash, lift2)["filter_x_dir"] == spec("downward", 150)  # no clash
    facing_clash = PickConfig(facing_filter=["forward", 90], filter_y_dir=["forward", 90])
    with pytest.raises(ConfigError, match="facing_filter"):
        resolve_filters(facing_clash, REFERENCE_CONVENTIONS["split_aloha"])
    # A third-axis filter keeps its key in the neutral form.
    assert neutral_form({"filter_y_dir": spec("upward", 100)}, fr3) == {
        "filter_y_dir": spec("upward", 100)
    }


# --------------------------------------------------------------------------------------------
# Candidate order (sections 4.4, 4.5)


def _reference_top(scores: np.ndarray, mask: np.ndarray, k: int = 20) -> list[int]:
    """The reference's own algorithm: sort (score, index) tuples, keep the first k."""
    pairs = sorted(zip(scores[mask].tolist(), np.flatnonzero(mask).tolist(), strict=True))
    return [index for _, index in pairs[:k]]


def test_top_by_score_breaks_ties_by_index() -> None:
    rng = np.random.default_rng(0)
    scores = rng.choice([0.1, 0.2, 0.3], size=500)
    mask = rng.random(500) < 0.3
    for k in (1, 5, 20, 400):
        expected = _reference_top(scores, mask, k)
        assert top_by_score(scores, np.flatnonzero(mask), k).tolist() == expected


def test_reference_order_draws_with_replacement_sorted() -> None:
    scores = np.tile([0.2, 0.1, 0.3, 0.1], 10)  # 40 poses
    mask = np.zeros(40, dtype=bool)
    mask[5:] = True
    order = reference_order(scores, mask, np.random.default_rng(3))
    assert order.outcome == "ok" and len(order) == 20
    assert order.top_candidates.tolist() == _reference_top(scores, mask)
    assert set(order.indices.tolist()) <= set(order.top_candidates.tolist())
    pairs = list(zip(order.scores.tolist(), order.indices.tolist(), strict=True))
    assert pairs == sorted(pairs)
    assert len(set(order.indices.tolist())) < 20  # duplicates occur
    # Fewer than 20 passing: still 20 draws, from the few.
    few = np.zeros(40, dtype=bool)
    few[[7, 30, 33]] = True
    order = reference_order(scores, few, np.random.default_rng(3))
    assert len(order) == 20 and set(order.indices.tolist()) <= {7, 30, 33}
    assert order.top_candidates.tolist() == [7, 33, 30]  # (0.1, 7), (0.1, 33), (0.3, 30)


def test_reference_draw_frequencies_follow_inverse_score_weights() -> None:
    scores = np.array([0.1, 0.2, 0.3, 0.5, 1.0] * 4)  # 20 candidates, weights 10:5:3.3:2:1
    mask = np.ones(20, dtype=bool)
    rng = np.random.default_rng(12345)
    counts = np.zeros(20)
    runs = 3000
    for _ in range(runs):
        order = reference_order(scores, mask, rng)
        counts += np.bincount(order.indices, minlength=20)
    weights = 1.0 / (scores + 1e-8)
    expected = runs * 20 * weights / weights.sum()
    statistic, p_value = chisquare(counts, expected)
    assert p_value > 1e-3, (statistic, counts, expected)
    # Score 0.1 is drawn about 10x as often as 1.0, 2x as often as 0.2.
    by_score = {s: counts[scores == s].sum() for s in (0.1, 0.2, 1.0)}
    assert by_score[0.1] / by_score[1.0] == pytest.approx(10.0, rel=0.08)
    assert by_score[0.1] / by_score[0.2] == pytest.approx(2.0, rel=0.05)


def test_reference_order_uses_only_the_passed_generator() -> None:
    scores = np.linspace(0.1, 1.0, 100)
    mask = np.ones(100, dtype=bool)
    a = reference_order(scores, mask, np.random.default_rng(7))
    b = reference_order(scores, mask, np.random.default_rng(7))
    c = reference_order(scores, mask, np.random.default_rng(8))
    assert a.indices.tolist() == b.indices.tolist()
    assert a.indices.tolist() != c.indices.tolist()


def test_reference_fallback_is_the_first_20_unfiltered_poses() -> None:
    scores = np.linspace(1.0, 0.1, 60)  # the best scores are at the end: fallback ignores them
    order = reference_order(scores, np.zeros(60, dtype=bool), np.random.default_rng(0))
    assert order.outcome == "fallback"
    assert order.indices.tolist() == list(range(20))
    assert order.top_candidates.tolist() == list(range(20))
    np.testing.assert_array_equal(order.scores, scores[:20])
    # With fewer than 20 poses the reference would raise IndexError: reported, not raised.
    small = reference_order(scores[:12], np.zeros(12, dtype=bool), np.random.default_rng(0))
    assert small.outcome == "filter_empty" and len(small) == 0
    assert "IndexError" in small.note


def test_strict_order_unique_candidates() -> None:
    scores = np.tile([0.2, 0.1], 30)
    mask = np.ones(60, dtype=bool)
    mask[:10] = False
    order = strict_order(scores, mask)
    assert order.outcome == "ok"
    assert order.indices.tolist() == _reference_top(scores, mask)
    assert len(set(order.indices.tolist())) == len(order)
    sampled = strict_order(scores, mask, np.random.default_rng(1), sample=True)
    assert len(sampled) == 20 and len(set(sampled.indices.tolist())) == 20
    assert mask[sampled.indices].all()
    pairs = list(zip(sampled.scores.tolist(), sampled.indices.tolist(), strict=True))
    assert pairs == sorted(pairs)
    assert sampled.indices.tolist() != order.indices.tolist()  # no index bias
    empty = strict_order(scores, np.zeros(60, dtype=bool))
    assert empty.outcome == "filter_empty" and len(empty) == 0 and empty.top_candidates.size == 0


def test_reversed_band_reference_fallback_and_strict_config_error() -> None:
    convention = REFERENCE_CONVENTIONS["fr3"]
    rows = [grasp_row(R_TOP_DOWN, (0.0, 0.0, 0.001 * i)) for i in range(15)]
    poses = post_process(GraspSet.from_array(np.stack(rows)), convention)
    reversed_band = ["downward", 140, 110]
    pick = PickConfig(filter_z_dir=reversed_band)
    selection = select_candidates(poses, convention, pick, np.eye(4), rng0(), rule_of(pick))
    assert selection.filter_result.passed == 0
    assert selection.order.outcome == "fallback"
    assert selection.order.indices.tolist() == list(range(20))  # 30 poses: 15 unflipped + 5
    # Strict: the config itself is rejected, and so is a strict selection that bypassed it.
    with pytest.raises(ValidationError, match="can never pass"):
        PickConfig(filter_z_dir=reversed_band, semantics="strict")
    with pytest.raises(ValidationError, match="can never pass"):
        PickConfig(approach_filter=["forward", 45, 135], semantics="strict")
    strict = pick.model_copy(update={"semantics": "strict"})
    with pytest.raises(ConfigError, match=r"filter_z_dir.*smaller angle first"):
        select_candidates(poses, convention, strict, np.eye(4), rng0(), rule_of(strict))
    with pytest.raises(ConfigError, match="larger angle first"):
        check_strict_filters({"filter_x_dir": spec("upward", 30, 60)})
    # Strict with filters that pass nothing is a filter_empty outcome, not a fallback.
    nothing = PickConfig(filter_z_dir=["upward", 10], semantics="strict")
    selection = select_candidates(poses, convention, nothing, np.eye(4), rng0(), rule_of(nothing))
    assert selection.order.outcome == "filter_empty" and len(selection.order) == 0


def test_select_candidates_base_frame_poses() -> None:
    convention = REFERENCE_CONVENTIONS["lift2"]
    rng = np.random.default_rng(4)
    rows = [
        grasp_row(R, rng.uniform(-0.05, 0.05, 3), score=s)
        for R, s in zip(
            Rotation.random(300, random_state=5).as_matrix(),
            rng.choice([0.1, 0.2], 300),
            strict=True,
        )
    ]
    poses = post_process(GraspSet.from_array(np.stack(rows)), convention)
    T_base_obj = make_T(yaw_matrix(0.7), [0.45, -0.1, 0.05])
    pick = PickConfig(
        approach_filter=["downward", 120], facing_filter=["forward", 90], direction_to_obj="right"
    )
    selection = select_candidates(
        poses, convention, pick, T_base_obj, np.random.default_rng(0), rule_of(pick)
    )
    T_base_ee = base_frame_poses(poses, T_base_obj)
    np.testing.assert_allclose(selection.T_base_ee, T_base_ee, atol=1e-15)
    full = filter_poses(T_base_ee, selection.filters, "right", T_base_obj)
    assert full.masks.keys() == selection.filter_result.masks.keys()
    for key, mask in full.masks.items():
        np.testing.assert_array_equal(selection.filter_result.masks[key], mask)
    np.testing.assert_allclose(
        selection.candidate_T_base_ee, T_base_ee[selection.order.indices], atol=1e-15
    )
    assert selection.filter_sources == {
        "filter_x_dir": "approach_filter",
        "filter_z_dir": "facing_filter",
    }
    counts = selection.counts()
    assert counts["total"] == 600 and counts["grasps"] == 300
    assert counts["passed"] == int(full.combined.sum()) > 0
    assert set(counts) == {
        "grasps",
        "total",
        "passed",
        "passed_filter_x_dir",
        "passed_filter_z_dir",
        "passed_direction_to_obj",
    }


# --------------------------------------------------------------------------------------------
# Grasp file validation


def _save(tmp_path: Path, array: np.ndarray, name: str = "grasps.npy") -> Path:
    path = tmp_path / name
    np.save(path, array)
    return path


def _valid(n: int = 6) -> np.ndarray:
    return np.stack([grasp_row(R_TOP_DOWN, (0.0, 0.0, 0.01 * i)) for i in range(n)]).astype(
        np.float32
    )


def test_load_valid_file(tmp_path: Path) -> None:
    grasps = load_grasp_file(_save(tmp_path, _valid()))
    assert len(grasps) == 6 and grasps.rotations.shape == (6, 3, 3)
    assert grasps.rotations.dtype == np.float64
    poses = post_process(grasps, REFERENCE_CONVENTIONS["fr3"])
    for shared in (grasps.scores, grasps.rotations, poses.grasp_rotations, poses.scores):
        with pytest.raises(ValueError, match="read-only"):
            shared[0] = 0.0  # sets and poses are shared between selections, never edited
    np.testing.assert_allclose(grasps.translations[:, 2], 0.01 * np.arange(6), rtol=1e-6)


def _corrupt(row: int, column: int, value: float) -> np.ndarray:
    array = _valid()
    array[row, column] = value
    return array


@pytest.mark.parametrize(
    ("array", "pattern"),
    [
        (_valid()[:, :16], r"shape: expected an N x 17 grasp array.*\(6, 16\)"),
        (_valid()[0], r"shape: .*\(17,\)"),
        (np.zeros((0, 17), np.float32), "shape: holds no grasps"),
        (_valid().astype(np.int64), "dtype: expected floating-point values, got dtype int64"),
        (_corrupt(3, 3, np.nan), r"row 3 column 3 \(depth\): value nan is not finite"),
        (_corrupt(4, 14, np.inf), r"row 4 column 14 \(translation y\): value inf is not finite"),
        (_corrupt(2, 0, 0.0), r"row 2 column 0 \(score\): value 0.0 must be > 0"),
        (_corrupt(1, 0, -0.1), r"row 1 column 0 \(score\)"),
        (_corrupt(5, 1, -0.01), r"row 5 column 1 \(width\).*must be >= 0"),
        (_corrupt(2, 3, -0.01), r"row 2 column 3 \(depth\).*must be >= 0"),
        (_corrupt(4, 4, 0.01), r"row 4 columns 4-12 \(rotation\): rotation is not orthonormal"),
    ],
)
def test_grasp_file_errors_name_file_and_cell(
    tmp_path: Path, array: np.ndarray, pattern: str
) -> None:
    path = _save(tmp_path, array)
    with pytest.raises(InputFileError, match=pattern) as info:
        load_grasp_file(path)
    assert str(info.value).startswith(str(path))


def test_grasp_file_reflection_and_tolerance(tmp_path: Path) -> None:
    array = _valid()
    array[3, 4:13] = (-R_TOP_DOWN).ravel()  # orthonormal, det -1
    with pytest.raises(InputFileError, match=r"row 3 columns 4-12.*determinant -1"):
        load_grasp_file(_save(tmp_path, array))
    # Within the 1e-3 tolerance: accepted (float32 files are not exactly orthonormal).
    ok = _valid()
    ok[2, 4:13] = (R_TOP_DOWN * 1.0004).ravel()
    assert len(load_grasp_file(_save(tmp_path, ok, "ok.npy"))) == 6


def test_grasp_file_unreadable(tmp_path: Path) -> None:
    with pytest.raises(InputFileError, match="not found"):
        load_grasp_file(tmp_path / "missing.npy")
    garbage = tmp_path / "garbage.npy"
    garbage.write_text("not numpy")
    with pytest.raises(InputFileError, match=r"garbage.npy: cannot read as a .npy array"):
        load_grasp_file(garbage)
    archive = tmp_path / "two.npz"
    np.savez(archive, a=_valid())
    with pytest.raises(InputFileError, match="npz archive"):
        load_grasp_file(archive)


# --------------------------------------------------------------------------------------------
# Shared example grasp files (section 11)


def _random_base_object_pose(rng: np.random.Generator) -> np.ndarray:
    yaw = rng.uniform(-np.pi, np.pi)
    return make_T(yaw_matrix(yaw), [rng.uniform(0.3, 0.6), rng.uniform(-0.3, 0.3), 0.02])


def test_canonical_filters_select_identical_grasps_across_robots(
    example_objects: list[Path],
) -> None:
    rng = np.random.default_rng(2026)
    for folder in example_objects:
        grasps = load_grasp_file(folder / "Aligned_grasp_sparse.npy")
        poses = {r: post_process(grasps, REFERENCE_CONVENTIONS[r]) for r in ROBOTS}
        for _ in range(25):
            T_base_obj = _random_base_object_pose(rng)
            seed = int(rng.integers(1 << 30))
            selections = {
                r: select_candidates(
                    poses[r],
                    REFERENCE_CONVENTIONS[r],
                    PickConfig(**canonical_filters(r)),
                    T_base_obj,
                    np.random.default_rng(seed),
                    rule_of(PickConfig(**canonical_filters(r))),
                )
                for r in ROBOTS
            }
            fr3 = selections["fr3"]
            assert fr3.filter_result.passed > 0, folder
            for robot in ROBOTS[1:]:
                other = selections[robot]
                np.testing.assert_array_equal(
                    other.filter_result.combined, fr3.filter_result.combined, err_msg=robot
                )
                # Ranked lists and draws match too under the same generator state.
                assert other.order.top_candidates.tolist() == fr3.order.top_candidates.tolist()
                assert other.order.indices.tolist() == fr3.order.indices.tolist()
                # Same physical grasps: the TCP points agree, the EE origins differ by the
                # tcp_offset along the shared approach axis.
                idx = fr3.order.indices
                T_a, T_b = fr3.T_base_ee_at(idx), other.T_base_ee_at(idx)
                a = T_a[:, :3, 2]
                offset = REFERENCE_CONVENTIONS[robot].tcp_offset - 0.1043
                np.testing.assert_allclose(T_b[:, :3, 3], T_a[:, :3, 3] - a * offset, atol=1e-12)


def test_neutral_filters_match_canonical_masks(example_objects: list[Path]) -> None:
    grasps = load_grasp_file(example_objects[0] / "Aligned_grasp_sparse.npy")
    neutral = PickConfig(approach_filter=["downward", 140], facing_filter=["forward", 90])
    T_base_obj = make_T(yaw_matrix(1.1), [0.5, 0.1, 0.0])
    for robot in ROBOTS:
        convention = REFERENCE_CONVENTIONS[robot]
        poses = post_process(grasps, convention)
        rng = np.random.default_rng(0)
        a = select_candidates(poses, convention, neutral, T_base_obj, rng, rule_of(neutral))
        b = select_candidates(
            poses,
            convention,
            PickConfig(**canonical_filters(robot)),
            T_base_obj,
            rng,
            rule_of(PickConfig(**canonical_filters(robot))),
        )
        np.testing.assert_array_equal(a.filter_result.combined, b.filter_result.combined)


def test_bottle_0_passes_430_of_6000_at_any_yaw(examples_dir: Path) -> None:
    path = examples_dir / "objects/recyclable_garbage/bottle_0/Aligned_grasp_sparse.npy"
    grasps = load_grasp_file(path)
    assert len(grasps) == 3000
    rng = np.random.default_rng(0)
    yaws = np.concatenate([np.linspace(-np.pi, np.pi, 73), rng.uniform(-np.pi, np.pi, 50)])
    for robot in ROBOTS:
        convention = REFERENCE_CONVENTIONS[robot]
        poses = post_process(grasps, convention)
        filters = PickConfig(**canonical_filters(robot)).axis_filters()
        for yaw in yaws:
            T_base_obj = make_T(yaw_matrix(yaw), [0.5, 0.0, 0.02])
            result = filter_ee_poses(poses, T_base_obj, filters)
            assert (result.total, result.passed) == (6000, 430), (robot, yaw)


def test_example_reference_order_top_block_and_duplicates(
    examples_dir: Path,
) -> None:
    path = examples_dir / "objects/recyclable_garbage/bottle_0/Aligned_grasp_sparse.npy"
    convention = REFERENCE_CONVENTIONS["fr3"]
    poses = post_process(load_grasp_file(path), convention)
    pick = PickConfig(**canonical_filters("fr3"))
    T_base_obj = make_T(yaw_matrix(0.3), [0.5, 0.0, 0.02])
    selection = select_candidates(
        poses, convention, pick, T_base_obj, np.random.default_rng(9), rule_of(pick)
    )
    order = selection.order
    assert order.top_candidates.tolist() == _reference_top(
        poses.scores, selection.filter_result.combined
    )
    assert np.all(order.scores == np.float32(0.1))  # the lowest-score block fills the top 20
    assert len(np.unique(order.indices)) < 20
