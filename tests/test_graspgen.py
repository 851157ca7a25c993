"""Antipodal grasp generator: layout, convention (checked on the shared examples), independent
collision check, contacts on the surface, force-closure scores, determinism, CLI."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from harness.cli import main as cli_main
from harness.objects import shapes
from harness.objects.graspgen import (
    DEPTHS,
    FRICTION_LEVELS,
    GraspGenParams,
    force_closure_score,
    generate_grasps,
)
from harness.objects.meshes import load_mesh

FINGER_LENGTH, FINGER_THICKNESS, HEIGHT, PALM = 0.06, 0.01, 0.02, 0.01


def surface_samples(mesh: trimesh.Trimesh, count: int = 200_000) -> np.ndarray:
    points, _ = trimesh.sample.sample_surface(mesh, count, seed=1)
    return np.vstack([points, mesh.vertices])


def grasp_frame(points: np.ndarray, row: np.ndarray) -> np.ndarray:
    """Points in the grasp frame (x approach, y closing, z height), origin at the translation."""
    rotation = row[4:13].astype(np.float64).reshape(3, 3)
    offset = points - row[13:16].astype(np.float64)
    # explicit sums instead of a BLAS matmul: multithreaded BLAS crawls on a busy machine
    return offset[:, :1] * rotation[0] + offset[:, 1:2] * rotation[1] + offset[:, 2:] * rotation[2]


def gripper_collides(local: np.ndarray, row: np.ndarray, margin: float = 2e-4) -> bool:
    """Independent check (point sampling, not the generator's boxes): surface points strictly
    inside a finger (from 2.1 mm outside width / 2 outwards) or the palm."""
    width, depth = float(row[1]), float(row[3])
    x, y, z = local[:, 0], local[:, 1], local[:, 2]
    in_height = np.abs(z) < HEIGHT / 2 - margin
    in_finger_x = (x > depth - FINGER_LENGTH + margin) & (x < depth - margin)
    outer = width / 2 + FINGER_THICKNESS - margin
    in_fingers = in_finger_x & (np.abs(y) > width / 2 + 0.0021) & (np.abs(y) < outer)
    in_palm = (
        (x > depth - FINGER_LENGTH - PALM + margin)
        & (x < depth - FINGER_LENGTH - margin)
        & (np.abs(y) < outer)
    )
    return bool(np.any(in_height & (in_fingers | in_palm)))


def finger_slab_half_extent(local: np.ndarray, row: np.ndarray) -> float:
    """Largest |y| of the object between the fingers' length and height (the reference width)."""
    depth = float(row[3])
    band = (
        (np.abs(local[:, 2]) < HEIGHT / 2)
        & (local[:, 0] > depth - FINGER_LENGTH)
        & (local[:, 0] < depth)
        & (np.abs(local[:, 1]) < float(row[1]) / 2 + 0.02)
    )
    return float(np.abs(local[band, 1]).max()) if band.any() else np.nan


def assert_layout(grasps: np.ndarray, max_width: float = 0.1) -> None:
    assert grasps.dtype == np.float32 and grasps.shape[1] == 17
    assert np.all(np.diff(grasps[:, 0]) >= 0), "rows sorted by score"
    assert set(np.round(grasps[:, 0].astype(np.float64), 1)) <= set(FRICTION_LEVELS)
    assert np.all((grasps[:, 1] > 0) & (grasps[:, 1] <= max_width + 1e-6))
    assert np.all(grasps[:, 2] == np.float32(0.02))
    assert set(np.round(grasps[:, 3].astype(np.float64), 3)) <= set(DEPTHS)
    assert np.all(grasps[:, 16] == -1)
    rotations = grasps[:, 4:13].astype(np.float64).reshape(-1, 3, 3)
    identity = np.broadcast_to(np.eye(3), rotations.shape)
    np.testing.assert_allclose(rotations @ rotations.transpose(0, 2, 1), identity, atol=1e-5)
    np.testing.assert_allclose(np.linalg.det(rotations), 1.0, atol=1e-5)


# --------------------------------------------------------------------------------------------
# Force-closure score


def test_box_across_opposite_face_centres_scores_best() -> None:
    score = force_closure_score(
        np.array([-0.02, 0.0, 0.0]),
        np.array([-1.0, 0.0, 0.0]),
        np.array([0.02, 0.0, 0.0]),
        np.array([1.0, 0.0, 0.0]),
    )
    assert score == pytest.approx(0.1)


@pytest.mark.parametrize(
    ("tilt_deg", "expected"),
    [(0.0, 0.1), (5.0, 0.1), (6.0, 0.2), (10.0, 0.2), (30.0, 0.6), (44.0, 1.0), (46.0, np.nan)],
)
def test_score_is_the_smallest_friction_level_that_holds(tilt_deg: float, expected: float) -> None:
    """Contact normal tilted from the closing line: force-closure needs mu >= tan(tilt)."""
    tilt = np.deg2rad(tilt_deg)
    n1 = np.array([-np.cos(tilt), np.sin(tilt), 0.0])
    score = force_closure_score(np.zeros(3), n1, np.array([0.05, 0, 0]), np.array([1.0, 0, 0]))
    if np.isnan(expected):
        assert np.isnan(score)
    else:
        assert score == pytest.approx(expected)


def test_pair_with_parallel_normals_is_not_force_closure() -> None:
    n = np.array([1.0, 0.0, 0.0])
    assert np.isnan(force_closure_score(np.zeros(3), n, np.array([0.05, 0, 0]), n))


# --------------------------------------------------------------------------------------------
# Generated grasps


MESHES = {
    "box": lambda: shapes.box((0.04, 0.06, 0.09)),
    "mug": lambda: shapes.mug(sections=24),
    "banana": lambda: shapes.banana(rings=24, sections=16),
    "plate": lambda: shapes.plate(sections=24),
}


@pytest.fixture(scope="module", params=sorted(MESHES))
def generated(request: pytest.FixtureRequest):
    mesh = MESHES[request.param]()
    return request.param, mesh, generate_grasps(mesh, n=150, seed=7)


def test_generated_layout_and_contacts_on_surface(generated) -> None:
    name, mesh, result = generated
    grasps = result.grasps
    assert len(grasps) == 150, name
    assert_layout(grasps)
    query = trimesh.proximity.ProximityQuery(mesh)
    contacts = result.contacts.reshape(-1, 3)
    assert np.abs(query.signed_distance(contacts)).max() < 1e-3, name
    # translation on the surface, where the approach enters (the examples' convention)
    assert np.abs(query.signed_distance(grasps[:, 13:16].astype(np.float64))).max() < 1e-4
    rotations = grasps[:, 4:13].astype(np.float64).reshape(-1, 3, 3)
    g_x, g_y = rotations[:, :, 0], rotations[:, :, 1]
    c1, c2 = result.contacts[:, 0], result.contacts[:, 1]
    span = c2 - c1
    distance = np.linalg.norm(span, axis=1)
    np.testing.assert_allclose(distance, grasps[:, 1], atol=1e-5)  # width = contact distance
    np.testing.assert_allclose(span / distance[:, None], g_y, atol=1e-5)  # closing axis
    along = np.sum((0.5 * (c1 + c2) - grasps[:, 13:16]) * g_x, axis=1)
    assert np.all(along >= -1e-6) and np.all(along <= grasps[:, 3] - 0.005 + 1e-6)
    # the stored score is the force-closure score of the stored contacts and normals
    rescored = force_closure_score(c1, result.normals[:, 0], c2, result.normals[:, 1])
    np.testing.assert_allclose(rescored, grasps[:, 0], atol=1e-6)


def test_generated_grasps_are_collision_free(generated) -> None:
    name, mesh, result = generated
    points = surface_samples(mesh)
    for row in result.grasps.astype(np.float64):
        local = grasp_frame(points, row)
        assert not gripper_collides(local, row), (name, row)
        # the fingers touch the object: width is the opening at which they meet it
        assert finger_slab_half_extent(local, row) == pytest.approx(row[1] / 2, abs=2.1e-3)
    # gripper box centres are outside the solid (a ray-parity test independent of MuJoCo)
    rotations = result.grasps[:, 4:13].astype(np.float64).reshape(-1, 3, 3)
    depth = result.grasps[:, 3].astype(np.float64)
    behind = (depth - FINGER_LENGTH - PALM / 2)[:, None]
    palm = result.grasps[:, 13:16] + rotations[:, :, 0] * behind
    assert not mesh.contains(palm).any()


def test_box_grasps_all_score_best() -> None:
    result = generate_grasps(shapes.box((0.04, 0.06, 0.09)), n=100, seed=3)
    assert np.all(result.grasps[:, 0] == np.float32(0.1))
    widths = np.round(result.grasps[:, 1].astype(np.float64), 3)
    assert set(widths) <= {0.04, 0.06, 0.09}  # across opposite faces


def test_regeneration_is_byte_identical(tmp_path: Path) -> None:
    mesh = shapes.banana(rings=20, sections=16)
    paths = []
    for i, seed in enumerate((5, 5, 6)):
        paths.append(generate_grasps(mesh, n=120, seed=seed).save(tmp_path / f"g{i}.npy"))
    assert paths[0].read_bytes() == paths[1].read_bytes()
    assert paths[0].read_bytes() != paths[2].read_bytes()


def test_max_width_is_respected() -> None:
    mesh = shapes.box((0.03, 0.05, 0.12))
    result = generate_grasps(mesh, n=80, seed=1, params=GraspGenParams(max_width=0.04))
    assert len(result.grasps) == 80
    widths = result.grasps[:, 1].astype(np.float64)
    assert np.all(widths <= 0.04) and np.all(np.round(widths, 3) == 0.03)


def test_impossible_object_returns_fewer_rows() -> None:
    """A 12 cm cube cannot be grasped with a 10 cm gripper: no rows, no error."""
    result = generate_grasps(shapes.box((0.12, 0.12, 0.12)), n=20, seed=0)
    assert result.grasps.shape == (0, 17)


# --------------------------------------------------------------------------------------------
# The convention, measured on the shared InternDataEngine examples


def test_example_grasp_convention(example_objects: list[Path]) -> None:
    """Reference grasps: translation on the surface with the approach entering there, and the
    object's largest |y| inside the fingers' slab equal to width / 2 (fingertips at
    translation + depth * g_x, fingers 6 cm long, 2 cm high)."""
    for folder in example_objects[::3]:
        mesh = load_mesh(folder / "Aligned_obj.usd")
        grasps = np.load(folder / "Aligned_grasp_sparse.npy").astype(np.float64)[::60]
        assert_layout(grasps.astype(np.float32))
        _, distance, triangle = trimesh.proximity.closest_point(mesh, grasps[:, 13:16])
        assert np.median(distance) < 5e-4, folder
        g_x = grasps[:, 4:13].reshape(-1, 3, 3)[:, :, 0]
        assert np.median(np.sum(mesh.face_normals[triangle] * g_x, axis=1)) < -0.5, folder
        points = surface_samples(mesh, 100_000)
        ratios = [finger_slab_half_extent(grasp_frame(points, r), r) / (r[1] / 2) for r in grasps]
        assert np.nanmedian(ratios) == pytest.approx(1.0, abs=0.01), folder


def test_generated_grasps_on_an_example_mesh(example_objects: list[Path]) -> None:
    mesh = load_mesh(example_objects[-1] / "Aligned_obj.usd")  # bottle_1, 3643 vertices
    result = generate_grasps(mesh, n=100, seed=0)
    assert len(result.grasps) == 100
    assert_layout(result.grasps)
    assert result.grasps[0, 0] == np.float32(0.1)
    points = surface_samples(mesh)
    for row in result.grasps.astype(np.float64):
        assert not gripper_collides(grasp_frame(points, row), row)


# --------------------------------------------------------------------------------------------
# CLI


def test_cli_generate(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "grasps.npy"
    assert cli_main(["grasps", "generate", "cube", "--out", str(out), "-n", "40"]) == 0
    assert "40 grasps" in capsys.readouterr().out
    grasps = np.load(out)
    assert grasps.shape == (40, 17)
    # --scale and --max-width: a 4 cm cube scaled by 2 no longer fits a 7 cm gripper
    out2 = tmp_path / "big.npy"
    args = ["grasps", "generate", "cube", "--out", str(out2), "-n", "10", "--scale", "2"]
    assert cli_main([*args, "--max-width", "0.07"]) == 0
    assert np.load(out2).shape == (0, 17)
    assert "warning: only 0 of 10" in capsys.readouterr().out


def test_cli_generate_bad_mesh(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / "nope.stl"
    assert cli_main(["grasps", "generate", str(missing), "--out", str(tmp_path / "g.npy")]) == 2
    err = capsys.readouterr().err
    assert "nope.stl" in err and "not found" in err
