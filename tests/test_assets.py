"""ObjectAsset: mesh formats, USD raw points, validation errors, cached CoACD, mass properties,
grasp-file naming, default objects and the ``harness objects`` commands."""

from __future__ import annotations

import warnings
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import TypeVar

import numpy as np
import pytest
import trimesh
import yaml

from harness.cli import main as cli_main
from harness.errors import InputFileError
from harness.objects import assets, decomposition, mass, shapes
from harness.objects.assets import ObjectAsset, find_grasp_file, resolve_mesh
from harness.objects.decomposition import CoacdParams
from harness.objects.meshes import load_mesh, triangulate
from harness.robots.facts import max_jaw_opening

T = TypeVar("T")


@pytest.fixture(autouse=True)
def isolated_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Every test decomposes into its own cache directory."""
    root = tmp_path / "cache"
    monkeypatch.setenv("PICK_HARNESS_CACHE", str(root))
    return root / "coacd"


# --------------------------------------------------------------------------------------------
# The shared InternDataEngine examples


def test_example_objects_load_from_usd_in_metres(example_objects: list[Path]) -> None:
    from pxr import Usd, UsdGeom

    assert len(example_objects) == 8
    for folder in example_objects:
        usd = folder / "Aligned_obj.usd"
        # The stage claims centimetres; the raw points are metres and are used as they are.
        assert UsdGeom.GetStageMetersPerUnit(Usd.Stage.Open(str(usd))) == pytest.approx(0.01)
        mesh = load_mesh(usd)
        assert 0.02 < mesh.extents.max() < 0.3, folder  # a hand-sized object in metres
        assert np.isfinite(mesh.vertices).all() and len(mesh.faces) > 1000
        grasp_file = find_grasp_file(usd)
        assert grasp_file == folder / "Aligned_grasp_sparse.npy"
        points = np.load(grasp_file)[:, 13:16].astype(np.float64)
        lo, hi = mesh.bounds
        assert np.all(points >= lo - 1e-3) and np.all(points <= hi + 1e-3), folder


def load_two_at_a_time(load: Callable[[T], ObjectAsset], items: list[T]) -> list[ObjectAsset]:
    """``load`` of every item, two at a time, in order. Each fresh load runs CoACD in its own
    child process (``run_coacd_bounded``; ~140 s of CPU for the eight examples, 66 s of it
    obj_10's), so two threads keep both cores busy; every load decomposes into the test's own
    cache, so the pieces are the ones one load at a time would give."""
    with ThreadPoolExecutor(max_workers=2) as pool:
        return list(pool.map(load, items))


@pytest.mark.slow
def test_example_objects_full_asset_load(example_objects: list[Path]) -> None:
    """Every example through ObjectAsset.load: CoACD pieces inside the bounds, sane inertia."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # obj_10 is not closed
        usds = [folder / "Aligned_obj.usd" for folder in example_objects]
        assets_ = load_two_at_a_time(ObjectAsset.load, usds)
    for folder, asset in zip(example_objects, assets_, strict=True):
        assert asset.grasp_path == folder / "Aligned_grasp_sparse.npy"
        assert asset.grasp_count == 3000
        assert 1 <= len(asset.collision_pieces) <= asset.coacd_params.max_convex_hull
        lo, hi = asset.bounds
        for vertices, _ in asset.collision_pieces:
            assert np.all(vertices >= lo - 2e-3) and np.all(vertices <= hi + 2e-3)
        assert np.all(np.linalg.eigvalsh(asset.inertia) > 0)
        assert np.all((asset.center_of_mass > lo) & (asset.center_of_mass < hi))


# --------------------------------------------------------------------------------------------
# Formats, USD details, scale


@pytest.mark.parametrize("suffix", [".obj", ".stl", ".glb", ".gltf", ".ply"])
def test_trimesh_formats_round_trip(tmp_path: Path, suffix: str) -> None:
    box = trimesh.creation.box(extents=(0.03, 0.05, 0.07))
    path = tmp_path / f"box{suffix}"
    box.export(path)
    mesh = load_mesh(path)
    np.testing.assert_allclose(mesh.extents, [0.03, 0.05, 0.07], atol=1e-6)
    assert mesh.volume == pytest.approx(0.03 * 0.05 * 0.07, rel=1e-5)


USDA_QUAD_CUBE = """#usda 1.0
(
    metersPerUnit = 0.01
    upAxis = "Z"
)
def Xform "World"
{
    def Xform "Aligned"
    {
        def Mesh "mesh"
        {
            double3 xformOp:translate = (0.5, 0, 0)
            uniform token[] xformOpOrder = ["xformOp:translate"]
            int[] faceVertexCounts = [4, 4, 4, 4, 4, 4]
            int[] faceVertexIndices = [0, 3, 2, 1,  4, 5, 6, 7,  0, 1, 5, 4,
                                       1, 2, 6, 5,  2, 3, 7, 6,  3, 0, 4, 7]
            point3f[] points = [(-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1),
                                (-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1)]
        }
    }
}
"""


def test_usd_polygons_triangulated_raw_points_times_scale(tmp_path: Path) -> None:
    path = tmp_path / "Aligned_obj.usda"
    path.write_text(USDA_QUAD_CUBE)
    mesh = load_mesh(path, scale=(0.01, 0.02, 0.03))
    assert len(mesh.faces) == 12 and mesh.is_watertight and mesh.volume > 0
    # raw points (a 2-unit cube) times the scale; metersPerUnit is ignored; the mesh prim's
    # own translate (0.5 units along x) is applied before the scale.
    np.testing.assert_allclose(mesh.bounds, [[-0.005, -0.02, -0.03], [0.015, 0.02, 0.03]])


def test_triangulate_fans_mixed_polygons() -> None:
    faces = triangulate(np.array([3, 4, 5]), np.arange(12))
    assert faces.tolist() == [
        [0, 1, 2],
        [3, 4, 5],
        [3, 5, 6],
        [7, 8, 9],
        [7, 9, 10],
        [7, 10, 11],
    ]


def test_mass_properties_of_a_box_are_analytic(tmp_path: Path) -> None:
    path = tmp_path / "box.obj"
    trimesh.creation.box(extents=(0.02, 0.04, 0.06)).export(path)
    asset = ObjectAsset.load(path, scale=(2.0, 1.0, 1.0), mass=0.3, friction=0.7)
    a, b, c = 0.04, 0.04, 0.06
    expected = 0.3 / 12 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
    np.testing.assert_allclose(asset.inertia, expected, atol=1e-12)
    np.testing.assert_allclose(asset.center_of_mass, 0.0, atol=1e-12)
    assert (asset.mass, asset.friction) == (0.3, 0.7)
    assert asset.collision_source == "convex" and len(asset.collision_pieces) == 1
    np.testing.assert_allclose(asset.extents, [a, b, c])


def test_open_mesh_uses_hull_for_inertia_with_warning(tmp_path: Path) -> None:
    box = trimesh.creation.box(extents=(0.04, 0.04, 0.04))
    open_box = trimesh.Trimesh(box.vertices, box.faces[:-2])  # one face missing
    path = tmp_path / "open.obj"
    open_box.export(path)
    with pytest.warns(RuntimeWarning, match="not a closed solid"):
        com, inertia = mass.mass_properties(load_mesh(path), 0.1, path)
    np.testing.assert_allclose(inertia, np.eye(3) * 0.1 / 6 * 0.04**2, atol=1e-12)
    np.testing.assert_allclose(com, 0.0, atol=1e-12)


# --------------------------------------------------------------------------------------------
# Bad meshes: one error naming the file


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        ("missing.obj", None, "not found"),
        ("mesh.fbx", "whatever", "unsupported mesh format"),
        ("empty.obj", "", "empty"),
        ("nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 3 4\n", "NaN"),
        ("flat.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n", "zero volume"),
        ("broken.usd", "this is not a USD file", "cannot read USD"),
        ("nomesh.usda", '#usda 1.0\ndef Xform "World" {}\n', "no UsdGeom.Mesh"),
    ],
)
def test_bad_meshes_raise_naming_the_file(
    tmp_path: Path, name: str, content: str | None, message: str
) -> None:
    path = tmp_path / name
    if content is not None:
        path.write_text(content)
    with pytest.raises(InputFileError, match=message) as info:
        ObjectAsset.load(path)
    assert str(path) in str(info.value)


def test_bad_mass_and_scale_are_rejected(tmp_path: Path) -> None:
    path = tmp_path / "box.obj"
    trimesh.creation.box(extents=(0.04, 0.04, 0.04)).export(path)
    with pytest.raises(InputFileError, match="mass"):
        ObjectAsset.load(path, mass=0.0)
    with pytest.raises(InputFileError, match="scale"):
        ObjectAsset.load(path, scale=(1.0, -1.0, 1.0))


def test_cli_show_bad_mesh_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = _write(tmp_path / "flat.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n")
    assert cli_main(["objects", "show", str(path)]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and "zero volume" in err


# --------------------------------------------------------------------------------------------
# Collision geometry and its cache


def _bottle(tmp_path: Path) -> Path:
    path = tmp_path / "bottle.obj"
    path.write_text(shapes.obj_text(shapes.bottle(sections=12)))
    return path


def test_coacd_result_is_cached_on_disk(tmp_path: Path, isolated_cache: Path) -> None:
    path = _bottle(tmp_path)
    runs = decomposition.DECOMPOSITION_RUNS
    first = ObjectAsset.load(path)
    assert first.collision_source == "coacd"
    assert runs + 1 == decomposition.DECOMPOSITION_RUNS
    cached = sorted(isolated_cache.glob("*.npz"))
    assert len(cached) == 1
    second = ObjectAsset.load(path)
    assert second.collision_source == "cache"
    assert runs + 1 == decomposition.DECOMPOSITION_RUNS  # not decomposed again
    assert len(second.collision_pieces) == len(first.collision_pieces) >= 2
    for (v1, f1), (v2, f2) in zip(first.collision_pieces, second.collision_pieces, strict=True):
        np.testing.assert_array_equal(v1, v2)
        np.testing.assert_array_equal(f1, f2)
    # scale and CoACD parameters are part of the key
    ObjectAsset.load(path, scale=(2.0, 2.0, 2.0))
    ObjectAsset.load(path, coacd_params=CoacdParams(max_convex_hull=4))
    assert runs + 3 == decomposition.DECOMPOSITION_RUNS
    assert len(list(isolated_cache.glob("*.npz"))) == 3


def test_convex_meshes_skip_coacd(tmp_path: Path, isolated_cache: Path) -> None:
    path = tmp_path / "ball.obj"
    path.write_text(shapes.obj_text(shapes.ball(0.03, subdivisions=2)))
    runs = decomposition.DECOMPOSITION_RUNS
    asset = ObjectAsset.load(path)
    assert asset.collision_source == "convex" and len(asset.collision_pieces) == 1
    assert runs == decomposition.DECOMPOSITION_RUNS
    assert not isolated_cache.exists()


def test_coacd_failure_falls_back_to_hull(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def failing(mesh: trimesh.Trimesh, params: CoacdParams) -> list:
        raise RuntimeError("simulated CoACD crash")

    monkeypatch.setattr(decomposition, "run_coacd", failing)
    path = _bottle(tmp_path)
    with pytest.warns(RuntimeWarning, match="convex decomposition failed"):
        asset = ObjectAsset.load(path)
    assert asset.collision_source == "convex_hull" and len(asset.collision_pieces) == 1
    hull = trimesh.Trimesh(*asset.collision_pieces[0])
    assert hull.volume == pytest.approx(asset.mesh.convex_hull.volume)


def test_corrupt_cache_file_is_recomputed(tmp_path: Path, isolated_cache: Path) -> None:
    path = _bottle(tmp_path)
    ObjectAsset.load(path)
    (cache_file,) = isolated_cache.glob("*.npz")
    cache_file.write_bytes(b"garbage")
    again = ObjectAsset.load(path)
    assert again.collision_source == "coacd"


# --------------------------------------------------------------------------------------------
# Grasp files and default objects


def test_grasp_file_naming_rule(tmp_path: Path) -> None:
    box = trimesh.creation.box(extents=(0.04, 0.04, 0.04))
    for folder, mesh_name, grasp_name in [
        ("ref", "Aligned_obj.obj", "Aligned_grasp_sparse.npy"),
        ("stem", "thing.obj", "thing_grasps.npy"),
        ("plain", "thing.obj", "grasps.npy"),
    ]:
        (tmp_path / folder).mkdir()
        mesh_path = tmp_path / folder / mesh_name
        box.export(mesh_path)
        np.save(tmp_path / folder / grasp_name, np.zeros((2, 17), np.float32))
        asset = ObjectAsset.load(mesh_path)
        assert asset.grasp_path == tmp_path / folder / grasp_name
        assert asset.grasp_count == 2
    np.save(tmp_path / "ref" / "other.npy", np.zeros((3, 17), np.float32))
    assert find_grasp_file(tmp_path / "ref" / "Aligned_obj.obj", "other.npy").name == "other.npy"
    with pytest.raises(InputFileError, match="npy_name"):
        find_grasp_file(tmp_path / "ref" / "Aligned_obj.obj", "absent.npy")
    with pytest.raises(InputFileError, match="grasp file not found"):
        ObjectAsset.load(tmp_path / "ref" / "Aligned_obj.obj", grasps=tmp_path / "nope.npy")
    explicit = ObjectAsset.load(tmp_path / "stem" / "thing.obj", grasps="../ref/other.npy")
    assert explicit.grasp_count == 3
    (tmp_path / "none").mkdir()
    box.export(tmp_path / "none" / "x.obj")
    assert ObjectAsset.load(tmp_path / "none" / "x.obj").grasp_path is None


def test_resolve_mesh_paths_and_default_names(tmp_path: Path) -> None:
    mesh = tmp_path / "sub" / "m.obj"
    mesh.parent.mkdir()
    trimesh.creation.box(extents=(0.04, 0.04, 0.04)).export(mesh)
    assert resolve_mesh("sub/m.obj", tmp_path) == mesh
    assert resolve_mesh(str(mesh), Path("/")) == mesh
    cube = resolve_mesh("cube", tmp_path)
    assert cube == assets.default_objects_dir() / "cube" / "cube.obj"
    with pytest.raises(InputFileError, match="not a default object") as info:
        resolve_mesh("unicorn", tmp_path)
    assert "cube" in str(info.value)


def test_default_object_set_files() -> None:
    names = assets.list_default_objects()
    assert set(names) == {spec.name for spec in shapes.DEFAULT_OBJECTS}
    assert len(names) >= 8
    categories = {assets.load_object_info(n)["category"] for n in names}
    assert {"cube", "box", "can", "bottle", "mug", "banana", "ball", "plate"} <= categories
    fits_piper = []
    for name in names:
        info = assets.load_object_info(name)
        folder = assets.default_objects_dir() / name
        mesh = load_mesh(folder / info["mesh"])
        assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
        np.testing.assert_allclose(mesh.bounds.mean(axis=0), 0.0, atol=1e-6)
        assert find_grasp_file(folder / info["mesh"]) == folder / "grasps.npy"
        grasps = np.load(folder / "grasps.npy")
        assert grasps.shape == (3000, 17) and grasps.dtype == np.float32
        assert np.all(np.diff(grasps[:, 0]) >= 0)
        lo, hi = mesh.bounds
        assert np.all((grasps[:, 13:16] >= lo - 1e-4) & (grasps[:, 13:16] <= hi + 1e-4))
        assert info["grasp_count"] == 3000 and info["vertices"] == len(mesh.vertices)
        fraction = float(np.mean(grasps[:, 1] <= max_jaw_opening("split_aloha")))
        assert info["grippers"]["split_aloha"]["fraction"] == pytest.approx(fraction, abs=1e-3)
        if "split_aloha" in info["fits"]:
            fits_piper.append(name)
        assert 0.01 < info["mass"] < 1.0 and info["friction"] > 0
    np.testing.assert_allclose(load_mesh(resolve_mesh("cube", Path("."))).extents, 0.04)
    # the 7.4 cm can fits the reference 0.10 m piper100 jaw (not the SDK 0.07 m one)
    assert "cube" in fits_piper and "can" in fits_piper
    assert {"fr3", "lift2"} <= set(assets.load_object_info("can")["fits"])


def test_build_reproduces_committed_cube(tmp_path: Path) -> None:
    from harness.commands.objects import build_object

    build_object("cube", tmp_path, n=3000)
    committed = assets.default_objects_dir() / "cube"
    for name in ("cube.obj", "grasps.npy", "object.yaml"):
        assert (tmp_path / "cube" / name).read_bytes() == (committed / name).read_bytes(), name


@pytest.mark.slow
def test_every_default_object_loads_as_asset() -> None:
    def load(name: str) -> ObjectAsset:
        mass = assets.load_object_info(name)["mass"]
        return ObjectAsset.load(resolve_mesh(name, Path(".")), mass=mass)

    for asset in load_two_at_a_time(load, assets.list_default_objects()):
        assert 1 <= len(asset.collision_pieces) <= asset.coacd_params.max_convex_hull
        assert asset.grasp_count == 3000
        assert np.all(np.linalg.eigvalsh(asset.inertia) > 0)


# --------------------------------------------------------------------------------------------
# Commands


def test_objects_list_and_show_render(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert cli_main(["objects", "list"]) == 0
    listing = capsys.readouterr().out
    for name in ("cube", "mug", "banana", "plate"):
        assert name in listing
    png = tmp_path / "cube.png"
    assert cli_main(["objects", "show", "cube", "--render", str(png)]) == 0
    out = capsys.readouterr().out
    assert "vertices    8" in out and "(3000x17)" in out and "1 convex piece" in out
    from PIL import Image

    image = np.asarray(Image.open(png))
    assert image.shape == (400, 1440, 3)
    # the object is drawn: the centre of the first panel differs from the background corner
    assert np.abs(image[200, 240].astype(int) - image[390, 10].astype(int)).sum() > 30


def test_object_yaml_is_plain_yaml() -> None:
    path = assets.default_objects_dir() / "mug" / "object.yaml"
    info = yaml.safe_load(path.read_text())
    assert info["mesh"] == "mug.obj" and info["orientations"] == [[0.0, 0.0, 0.0]]
