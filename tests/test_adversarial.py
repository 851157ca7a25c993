"""Hostile and broken inputs, table-driven (issue 26): every input is refused with one line
naming the file and the key and a non-zero exit, or it runs and stores rows without ``error``;
nothing is written outside the run directory, no planted link is followed, nothing runs past
its limits.

Each case builds its input in ``tmp_path/work`` next to a ``victim`` file, runs the real CLI
(in-process: ``harness.cli.main``, or a child process where the case needs one) and checks the
three rules. The counts the issue asks for (tracebacks, hangs, exit 0 on broken input, outside
writes, followed links, dropped rows) are each one of these assertions.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import signal
import stat
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import faults
import pytest
import yaml

from harness import cli

ROOT = Path(__file__).resolve().parents[1]
FR3 = ROOT / "tasks" / "pick" / "fr3.yaml"
CUBE_OBJ = ROOT / "tasks" / "objects" / "cube" / "cube.obj"
CUBE_GRASPS = ROOT / "tasks" / "objects" / "cube" / "grasps.npy"
VICTIM_TEXT = "precious"
CASE_LIMIT_S = 60.0  # any case past this has hung (validate cases take well under a second)


def task_data(**object_changes: object) -> dict:
    data = yaml.safe_load(FR3.read_text(encoding="utf-8"))
    data["objects"][0].update({"mesh": str(CUBE_OBJ), "grasps": str(CUBE_GRASPS)})
    data["objects"][0].update(object_changes)
    return data


def write_yaml(path: Path, data: object) -> Path:
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return path


def sweep_data(**changes: object) -> dict:
    return {
        "name": "adv",
        "tasks": [str(FR3)],
        "episodes_per_point": 1,
        "record": "none",
        **changes,
    }


# -- input builders: each returns the argv (after ``harness``) for its work folder ------------


def fifo_task(work: Path) -> list[str]:
    os.mkfifo(work / "t.yaml")
    return ["validate", str(work / "t.yaml")]


def dev_zero_task(work: Path) -> list[str]:
    (work / "t.yaml").symlink_to("/dev/zero")
    return ["validate", str(work / "t.yaml")]


def fifo_sweep(work: Path) -> list[str]:
    os.mkfifo(work / "s.yaml")
    return ["sweep", str(work / "s.yaml"), "--out", str(work / "run")]


def usd_file(work: Path, counts: str, indices: str, points: str, sub: str | None) -> Path:
    layer = "" if sub is None else f"(\n    subLayers = [@./{sub}@]\n)\n"
    text = (
        f'#usda 1.0\n{layer}def Xform "World" {{\n  def Xform "Aligned" {{\n'
        f'    def Mesh "m" {{\n      point3f[] points = [{points}]\n'
        f"      int[] faceVertexCounts = [{counts}]\n      int[] faceVertexIndices = [{indices}]\n"
        "    }\n  }\n}\n"
    )
    path = work / "m.usda"
    path.write_text(text, encoding="utf-8")
    return path


TETRA = "(0,0,0),(0.05,0,0),(0,0.05,0),(0,0,0.05)"
TETRA_FACES = "0,2,1, 0,1,3, 0,3,2, 1,2,3"


def usd_task(work: Path, **usd: str | None) -> list[str]:
    args = {"counts": "3,3,3,3", "indices": TETRA_FACES, "points": TETRA, "sub": None, **usd}
    mesh = usd_file(work, **args)  # type: ignore[arg-type]
    return ["validate", str(write_yaml(work / "t.yaml", task_data(mesh=str(mesh))))]


def usd_fifo_sublayer(work: Path) -> list[str]:
    os.mkfifo(work / "sub.usda")
    return usd_task(work, sub="sub.usda")


def huge_mesh(work: Path) -> list[str]:
    mesh = work / "far.obj"
    mesh.write_text(
        "v 0 0 0\nv 1e31 0 0\nv 0 1e31 0\nv 0 0 1e31\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
    )
    return ["validate", str(write_yaml(work / "t.yaml", task_data(mesh=str(mesh))))]


def lying_npy(work: Path) -> list[str]:
    header = "{'descr': '<f8', 'fortran_order': False, 'shape': (1000000000000, 17), }"
    header = header.ljust(118) + "\n"
    path = work / "g.npy"
    path.write_bytes(b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header.encode())
    return ["validate", str(write_yaml(work / "t.yaml", task_data(grasps=str(path))))]


def task_with(**changes: object) -> Callable[[Path], list[str]]:
    def build(work: Path) -> list[str]:
        return ["validate", str(write_yaml(work / "t.yaml", task_data(**changes)))]

    return build


def sweep_with(**changes: object) -> Callable[[Path], list[str]]:
    def build(work: Path) -> list[str]:
        return ["validate", str(write_yaml(work / "s.yaml", sweep_data(**changes)))]

    return build


INTERNDATA_HEAD = "tasks:\n  - robots: []\n    skills: []\n"


def interndata(body: str) -> Callable[[Path], list[str]]:
    def build(work: Path) -> list[str]:
        (work / "i.yaml").write_text(INTERNDATA_HEAD + body, encoding="utf-8")
        return ["validate", str(work / "i.yaml")]

    return build


STRING_BOMB = "x:\n  l0: ab\n" + "".join(
    f"  l{i}: '${{x.l{i - 1}}}${{x.l{i - 1}}}'\n" for i in range(1, 35)
)
LIST_BOMB = "x:\n  l0: [a, b]\n" + "".join(
    f"  l{i}: ['${{x.l{i - 1}}}', '${{x.l{i - 1}}}']\n" for i in range(1, 41)
)
DEEP_CHAIN = "x:\n" + "".join(f"  a{i}: '${{x.a{i + 1}}}'\n" for i in range(3000)) + "  a3000: e\n"


def flags(*argv: str) -> Callable[[Path], list[str]]:
    def build(work: Path) -> list[str]:
        sweep = write_yaml(work / "s.yaml", sweep_data())
        return [a.replace("SWEEP", str(sweep)).replace("WORK", str(work)) for a in argv]

    return build


def out_is(target: str) -> Callable[[Path], list[str]]:
    def build(work: Path) -> list[str]:
        (work / "file").write_text("x", encoding="utf-8")
        out = target.replace("WORK", str(work))
        return ["run", str(FR3), "--episodes", "1", "--record", "none", "--out", out]

    return build


# -- issue 37: reads, parses, flags (each builder fails early: no episode runs) ---------------


def obj_including_fifo(include: str, command: str) -> Callable[[Path], list[str]]:
    """An OBJ whose ``mtllib`` (``include="mtl"``) or whose MTL's ``map_Kd`` (``"texture"``)
    names a FIFO: trimesh opened it and waited forever for a writer."""

    def build(work: Path) -> list[str]:
        mesh = work / "m.obj"
        if include == "mtl":
            os.mkfifo(work / "f.mtl")
            head = "mtllib f.mtl\n"
        else:
            os.mkfifo(work / "tex.png")
            (work / "a.mtl").write_text("newmtl m\nmap_Kd tex.png\n", encoding="utf-8")
            head = "mtllib a.mtl\nusemtl m\n"
        mesh.write_text(head + CUBE_OBJ.read_text(encoding="utf-8"), encoding="utf-8")
        if command == "validate":
            return ["validate", str(write_yaml(work / "t.yaml", task_data(mesh=str(mesh))))]
        if command == "generate":
            return ["grasps", "generate", str(mesh), "--out", str(work / "g.npy"), "-n", "10"]
        return ["objects", "show", str(mesh)]

    return build


def usd_symlink_loop(work: Path) -> list[str]:
    (work / "loop1.usda").symlink_to("loop2.usda")
    (work / "loop2.usda").symlink_to("loop1.usda")
    mesh = usd_file(work, "3,3,3,3", TETRA_FACES, TETRA, "loop1.usda")
    return ["grasps", "generate", str(mesh), "--out", str(work / "g.npy"), "-n", "10"]


def gltf_fifo_buffer(work: Path) -> list[str]:
    import trimesh

    trimesh.creation.box((0.05, 0.05, 0.05)).export(work / "b.gltf")
    buffers = sorted(work.glob("*.bin"))
    buffers[-1].unlink()
    os.mkfifo(buffers[-1])
    return ["objects", "show", str(work / "b.gltf")]


def mesh_symlink_loop(work: Path) -> list[str]:
    (work / "a.obj").symlink_to("b.obj")
    (work / "b.obj").symlink_to("a.obj")
    return ["objects", "show", str(work / "a.obj")]


def garbage_parquet_run(work: Path) -> list[str]:
    (work / "run").mkdir()
    (work / "run" / "episodes.parquet").write_bytes(b"PAR1 this is no parquet file")
    return ["report", str(work / "run"), "--no-videos"]


def garbage_npz(work: Path) -> list[str]:
    (work / "g.npz").write_bytes(b"PK\x03\x04 no zip archive")
    return ["grasps", "inspect", str(work / "g.npz"), "--robot", "fr3"]


def garbage_csv_runs(work: Path) -> list[str]:
    for name in ("a", "b"):
        (work / name).mkdir()
        (work / name / "episodes.csv").write_text("episode_id,foo\nx,1\n", encoding="utf-8")
    return ["compare", str(work / "a"), str(work / "b")]


def closed_port(work: Path) -> list[str]:
    import socket

    with socket.socket() as probe:  # a port that was free a moment ago: nothing listens
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    sweep = write_yaml(work / "s.yaml", sweep_data())
    return ["sweep", str(sweep), "--backend", "ray", "--address", f"127.0.0.1:{port}"]


SPELLED_TWICE = {
    "friction 1 and 1.0": {"object.friction": [1, 1.0]},
    "lift_th number and string": {"pick.lift_th": [0.02, "0.02"]},
    "validity on and true": {"pick.validity": ["on", True]},
}


@dataclass(frozen=True)
class Case:
    name: str
    build: Callable[[Path], list[str]]
    message: str  # the refusal line contains this (the file is checked separately)
    names_file: bool = True  # the line names a file of the work folder


CASES = [
    Case("fifo task", fifo_task, "is a FIFO"),
    Case("dev/zero link", dev_zero_task, "is a device"),
    Case("fifo sweep", fifo_sweep, "is a FIFO"),
    Case("usd fifo sublayer", usd_fifo_sublayer, "is a FIFO"),
    Case("usd negative counts", lambda w: usd_task(w, counts="3,-3,3,3"), "negative"),
    Case("usd counts mismatch", lambda w: usd_task(w, counts="3,3,3"), "faceVertexCounts sum"),
    Case("mesh 1e31 m", huge_mesh, "above 10 m"),
    Case("npy header 1e12 rows", lying_npy, "header claims"),
    Case("mass true", task_with(mass=True), "objects[0].mass"),
    Case(
        "placement x 1e300",
        task_with(placement={"pos_range": [[0, 0, 0], [1e300, 0, 0]]}),
        "objects[0].placement.pos_range",
    ),
    Case(
        "placement z 1e6",
        task_with(placement={"pos_range": [[0, 0, 1e6], [0, 0, 1e6]]}),
        "objects[0].placement.pos_range",
    ),
    Case(
        "duplicate grid value",
        sweep_with(axes={"pick.lift_th": [0.02, 2.0e-2]}),
        "axes.pick.lift_th[1]",
    ),
    Case(
        "100x100 grid",
        sweep_with(
            axes={
                "pick.lift_th": [0.01 + 0.001 * i for i in range(100)],
                "pick.t_eps": [0.001 + 0.0001 * i for i in range(100)],
            }
        ),
        "--max-points",
    ),
    Case("interpolation string bomb", interndata(STRING_BOMB), "longer than"),
    Case("interpolation list bomb", interndata(LIST_BOMB), "more than 200,000 nodes"),
    Case("interpolation chain 3000", interndata(DEEP_CHAIN), "nest more than"),
    Case("run --episodes 100001", flags("run", str(FR3), "--episodes", "100001"), "100001", False),
    Case(
        "--episodes-per-point 100001",
        flags("sweep", "SWEEP", "--episodes-per-point", "100001"),
        "100001",
        False,
    ),
    Case(
        "tune --episodes 100001", flags("tune", str(FR3), "--episodes", "100001"), "100001", False
    ),
    Case(
        "inspect --seed -1",
        flags("grasps", "inspect", str(CUBE_GRASPS), "--robot", "fr3", "--seed", "-1"),
        "-1",
        False,
    ),
    Case(
        "generate --seed -1",
        flags("grasps", "generate", str(CUBE_OBJ), "--out", "WORK/g.npy", "--seed", "-1"),
        "-1",
        False,
    ),
    Case(
        "generate -n 1e9",
        flags("grasps", "generate", str(CUBE_OBJ), "--out", "WORK/g.npy", "-n", "1000000000"),
        "1000000000",
        False,
    ),
    Case("sweep S --resume R", flags("sweep", "SWEEP", "--resume", "WORK"), "not both", False),
    Case("--force alone", flags("sweep", "SWEEP", "--force"), "--force only applies", False),
    Case(
        "--retry-errors alone",
        flags("sweep", "SWEEP", "--retry-errors"),
        "--retry-errors only applies",
        False,
    ),
    Case(
        "--address without ray",
        flags("sweep", "SWEEP", "--address", "127.0.0.1:6379"),
        "--address needs --backend ray",
        False,
    ),
    Case("--out an existing file", out_is("WORK/file"), "not a directory"),
    Case("--out /dev/null", out_is("/dev/null"), "not a directory", False),
    Case(  # replay makes missing output folders (issue 36), but only for an episode it finds
        "replay --record into a missing folder, no such episode",
        flags("replay", "WORK/norun", "x", "--record", "WORK/missing/dir/x.rrd"),
        "no episode 'x' in this run",
    ),
    # issue 37: the read rule (regular files only, loops refused, parse errors are input errors)
    Case("obj mtllib fifo: validate", obj_including_fifo("mtl", "validate"), "f.mtl is a FIFO"),
    Case("obj mtllib fifo: generate", obj_including_fifo("mtl", "generate"), "f.mtl is a FIFO"),
    Case("obj mtllib fifo: show", obj_including_fifo("mtl", "show"), "f.mtl is a FIFO"),
    Case("mtl map_Kd fifo: validate", obj_including_fifo("texture", "validate"), "tex.png is a"),
    Case("mtl map_Kd fifo: show", obj_including_fifo("texture", "show"), "tex.png is a FIFO"),
    Case("usd sublayer symlink loop", usd_symlink_loop, "is a symlink loop"),
    Case("mesh symlink loop", mesh_symlink_loop, "a symlink loop"),
    Case("gltf buffer fifo", gltf_fifo_buffer, ".bin is a FIFO"),
    Case("report: garbage parquet", garbage_parquet_run, "cannot read episode table"),
    Case("grasps inspect: garbage npz", garbage_npz, "cannot read as a .npy array"),
    Case("compare: garbage csv", garbage_csv_runs, "not an episode table"),
    # issue 37: flags checked before any work
    Case(
        "--set nested 3000 deep",
        flags("run", str(FR3), "--set", "pick.lift_th=" + "[" * 3000 + "]" * 3000),
        "nests more than 32 levels",
        False,
    ),
    Case(
        "--address not-a-host:xx",
        flags("sweep", "SWEEP", "--backend", "ray", "--address", "not-a-host:xx"),
        "port 'xx' is not a number",
        False,
    ),
    Case("--address closed port", closed_port, "connection refused", False),
    Case(
        "replay --video without extension",
        flags("replay", "WORK/norun", "x", "--video", "WORK/clip"),
        "unknown extension '(none)'; use .mp4",
    ),
    Case(
        "inspect --plot p.txt",
        flags("grasps", "inspect", str(CUBE_GRASPS), "--robot", "fr3", "--plot", "WORK/p.txt"),
        "unknown extension '.txt'; use .png or .pdf or .svg",
    ),
    Case(
        "objects show --render img",
        flags("objects", "show", "cube", "--render", "WORK/img"),
        "unknown extension '(none)'; use .png or .jpg or .jpeg",
    ),
    # issue 37: broken input that exited 0
    *[
        Case(f"sweep points: {name}", sweep_with(axes=axes), "spelled another way")
        for name, axes in SPELLED_TWICE.items()
    ],
    Case(
        "one key spelled two ways",
        sweep_with(axes={"object.friction": [0.5], "objects.0.friction": [1.0]}),
        "name the same key",
    ),
    Case("sweep named ..", sweep_with(name=".."), "not a plain file name"),
    Case(
        "axis objects.-1.mass",
        sweep_with(axes={"objects.-1.mass": [0.1]}),
        "negative list index -1",
    ),
    Case(
        "--set objects.-1.mass",
        flags("run", str(FR3), "--set", "objects.-1.mass=0.1"),
        "negative list index -1",
        False,
    ),
    Case("--record sample:0", flags("run", str(FR3), "--record", "sample:0"), "N >= 1", False),
    Case(
        "--asset-root without --interndata",
        flags("run", str(FR3), "--asset-root", "WORK"),
        "use it with --interndata",
        False,
    ),
    Case(
        "generate -n 0",
        flags("grasps", "generate", str(CUBE_OBJ), "--out", "WORK/g.npy", "-n", "0"),
        "0 is outside",
        False,
    ),
]


def snapshot(root: Path) -> dict[str, float]:
    """Every path under ``root`` (links not followed) and its mtime."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            path = Path(dirpath) / name
            with contextlib.suppress(OSError):
                out[str(path)] = path.lstat().st_mtime
    return out


def run_cli(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    """``harness ARGV`` in this process: (exit code, stderr). Argparse's usage errors exit 2."""
    previous = signal.getsignal(signal.SIGTERM)
    try:
        code = cli.main(argv)
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 1
    finally:
        signal.signal(signal.SIGTERM, previous)
    return code, capsys.readouterr().err


def assert_one_line_refusal(code: int, err: str, case: Case, work: Path) -> None:
    assert code != 0, f"{case.name}: exit 0 on broken input"
    assert "Traceback" not in err, f"{case.name}: traceback\n{err}"
    errors = [line for line in err.splitlines() if re.search(r"(^|: )error: ", line)]
    assert len(errors) == 1, f"{case.name}: expected one error line, got\n{err}"
    assert case.message in errors[0], f"{case.name}: {errors[0]!r}"
    if case.names_file:
        assert str(work) in errors[0] or Path(errors[0].split()[1]).name in os.listdir(work), (
            f"{case.name}: the line does not name the file: {errors[0]!r}"
        )


@pytest.mark.parametrize("case", CASES, ids=[case.name for case in CASES])
def test_adversarial_input_is_one_line_refusal(
    case: Case, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    work = tmp_path / "work"
    work.mkdir()
    victim = tmp_path / "victim.txt"
    victim.write_text(VICTIM_TEXT, encoding="utf-8")
    argv = case.build(work)
    before = snapshot(tmp_path)
    start = time.monotonic()
    code, err = run_cli(argv, capsys)
    assert time.monotonic() - start < CASE_LIMIT_S, f"{case.name}: ran past its limit"
    assert_one_line_refusal(code, err, case, work)
    after = snapshot(tmp_path)
    outside = [p for p in after if p not in before and not p.startswith(str(work))]
    assert not outside, f"{case.name}: wrote outside its folder: {outside}"
    assert victim.read_text(encoding="utf-8") == VICTIM_TEXT


# -- run-level cases: one finished run with a hostile task and object name ---------------------

HOSTILE_TASK = "<script>alert(1)</script>"
HOSTILE_OBJECT = "../../../../escape"


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``harness run`` of two episodes of a task named ``<script>...`` whose object is named
    ``../../../../escape`` (both must stay inert)."""
    folder = tmp_path_factory.mktemp("finished")
    data = task_data(name=HOSTILE_OBJECT)
    data["name"] = HOSTILE_TASK
    task = write_yaml(folder / "t.yaml", data)
    run_dir = folder / "run"
    code = cli.main(
        ["run", str(task), "--episodes", "2", "--record", "none", "--out", str(run_dir)]
    )
    assert code == 0
    return run_dir


def copy_run(run_dir: Path, where: Path) -> Path:
    import shutil

    return Path(shutil.copytree(run_dir, where / "run", symlinks=True))


def test_report_md_escapes_html_from_a_task_name(finished_run: Path) -> None:
    text = (finished_run / "report.md").read_text(encoding="utf-8")
    assert "<script" not in text
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in text
    assert not (finished_run.parent.parent / "escape").exists()


@pytest.mark.parametrize("planted", ["plots/success.png", "plots", "MUJOCO_LOG.TXT"])
def test_report_refuses_planted_links(
    planted: str, finished_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 26 class 2: ``report`` overwrote a linked plots/success.png and wrote into the
    target of a ``plots`` link."""
    run_dir = copy_run(finished_run, tmp_path)
    victim = tmp_path / "victim.png"
    victim.write_text(VICTIM_TEXT, encoding="utf-8")
    target_dir = tmp_path / "elsewhere"
    target_dir.mkdir()
    path = run_dir / planted
    if path.is_dir():
        import shutil

        shutil.rmtree(path)
    else:
        path.unlink(missing_ok=True)
    path.symlink_to(target_dir if planted == "plots" else victim)
    code, err = run_cli(["report", str(run_dir)], capsys)
    assert code == 2 and "Traceback" not in err
    assert "symlink" in err and planted in err, err
    assert victim.read_text(encoding="utf-8") == VICTIM_TEXT
    assert not list(target_dir.iterdir())


def test_a_planted_mujoco_log_link_is_refused_before_a_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    victim = tmp_path / "victim.txt"
    victim.write_text(VICTIM_TEXT, encoding="utf-8")
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    (run_dir / "MUJOCO_LOG.TXT").symlink_to(victim)
    code, err = run_cli(
        ["run", str(FR3), "--episodes", "1", "--record", "none", "--out", str(run_dir)], capsys
    )
    assert code == 2 and "MUJOCO_LOG.TXT in the run directory is a symlink" in err
    assert victim.read_text(encoding="utf-8") == VICTIM_TEXT
    assert not (run_dir / "episodes.jsonl").exists()


@pytest.mark.parametrize("witness", ["header", "rows"])
def test_resume_of_a_copied_run_refuses_an_edited_sweep(
    witness: str, finished_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 26 class 3: ``cp -r run/*`` drops ``.sweep.sha256``; an edited sweep.yaml then
    resumed under new physics. The header line and the rows' ``config_sha256`` still tell."""
    run_dir = copy_run(finished_run, tmp_path)
    (run_dir / ".sweep.sha256").unlink()
    sweep_yaml = run_dir / "sweep.yaml"
    text = sweep_yaml.read_text(encoding="utf-8")
    assert text.startswith("# config_sha256: ")
    # An edit of the physics (the object's friction is no longer written since issue 22 reads
    # it from the asset when the task sets none; the lift threshold is always there).
    edited = re.sub(r"lift_th: [0-9.e+-]+", "lift_th: 0.035", text, count=1)
    assert edited != text
    if witness == "rows":  # the header line removed too: only the rows remember
        edited = edited.split("\n", 1)[1]
    sweep_yaml.write_text(edited, encoding="utf-8")
    rows_before = (run_dir / "episodes.jsonl").read_text(encoding="utf-8")
    code, err = run_cli(["sweep", "--resume", str(run_dir), "--no-progress"], capsys)
    assert code == 2 and "changed since the run was created" in err, err
    assert (run_dir / "episodes.jsonl").read_text(encoding="utf-8") == rows_before


def test_random_choices_run_each_distinct_point_once(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 26 class 4: 30 draws over choices ran 30 episodes and kept 15 rows, exit 0."""
    from harness.config import load_sweep
    from harness.runs.expansion import expand

    path = write_yaml(
        tmp_path / "s.yaml",
        sweep_data(
            mode="random", points=30, random_axes={"pick.lift_th": {"choices": [0.02, 0.03]}}
        ),
    )
    episodes = expand(load_sweep(path), path)
    assert len(episodes) == 2 == len({e.resolved_id for e in episodes})
    assert "30 random draws gave 2 distinct points" in capsys.readouterr().err


def test_stdout_on_a_full_disk_is_one_line(tmp_path: Path) -> None:
    with open("/dev/full", "w") as full:
        result = subprocess.run(
            [sys.executable, "-m", "harness.cli", "validate", str(FR3)],
            stdout=full,
            stderr=subprocess.PIPE,
            text=True,
            env={**os.environ, "PYTHONPATH": str(ROOT)},
            timeout=120,
            check=False,
        )
    assert result.returncode == 2
    assert "Traceback" not in result.stderr and "Exception ignored" not in result.stderr
    assert result.stderr.strip().splitlines() == ["error: stdout/stderr: no space left on device"]


def _read_only_mount(path: Path) -> bool:
    path.mkdir()
    ok = (
        subprocess.run(
            ["mount", "-t", "tmpfs", "-o", "size=16m", "tmpfs", str(path)],
            capture_output=True,
            check=False,
        ).returncode
        == 0
    )
    return ok


@pytest.mark.parametrize("command", ["report", "resume", "fresh"])
def test_a_read_only_run_directory_is_one_line(
    command: str, finished_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 26 class 7: ``--resume``, ``report`` and a fresh sweep into a read-only folder
    were tracebacks. Root ignores permission bits, so the folder is a read-only tmpfs."""
    mount = tmp_path / "ro"
    if os.geteuid() == 0:
        if not _read_only_mount(mount):
            pytest.skip("cannot mount a tmpfs here")
        copy_run(finished_run, mount)
        subprocess.run(["mount", "-o", "remount,ro", str(mount)], check=True)
    else:
        mount.mkdir()
        copy_run(finished_run, mount)
        for folder in (mount, mount / "run"):
            folder.chmod(0o555)
    try:
        run_dir = mount / "run"
        sweep = write_yaml(tmp_path / "s.yaml", sweep_data())
        argv = {
            "report": ["report", str(run_dir)],
            "resume": ["sweep", "--resume", str(run_dir), "--no-progress"],
            "fresh": ["sweep", str(sweep), "--out", str(mount / "new"), "--no-progress"],
        }[command]
        code, err = run_cli(argv, capsys)
        assert code == 2 and "Traceback" not in err
        lines = [line for line in err.splitlines() if line.startswith("error: ")]
        assert len(lines) == 1, err
        reason = lines[0].lower()
        assert "read-only file system" in reason or "permission denied" in reason, err
    finally:
        if os.geteuid() == 0:
            subprocess.run(["umount", str(mount)], check=False)


def test_audit_files_of_a_hostile_object_name_stay_in_the_audit_folder(tmp_path: Path) -> None:
    """Issue 26 class 1: ``objects[0].name: ../../../../x`` wrote ``x_cleaned.npy`` seven
    levels above the audit folder."""
    import pandas as pd

    from harness.tuning.audit import write_cleaned

    out_dir = tmp_path / "a" / "b" / "c" / "audit"
    table = pd.DataFrame(
        [
            {
                "object": HOSTILE_OBJECT,
                "grasp_file": str(CUBE_GRASPS),
                "grasp_row": 0,
                "flagged": True,
            }
        ]
    )
    written = write_cleaned(table, out_dir)
    (path,) = written.values()
    assert path.parent == out_dir and path.is_file()
    assert not (tmp_path / "escape_cleaned.npy").exists()


# Output paths built from a name with an f-string, ``with_name`` or ``joinpath``: each must go
# through harness.files.safe_file_name / safe_child. The allowed ones read (never write) a
# fixed or derived name.
NAME_PATH = re.compile(r"""(/\s*f["'][^"']*\{)|with_name\(f|joinpath\(f|Path\(f["']""")
ALLOWED = {
    "harness/objects/assets.py": "reads <mesh stem>_grasps.npy beside a mesh",
    "harness/benchmarks/sharing.py": "reads tasks/pick/<robot>.yaml of a fixed robot list",
    "harness/benchmarks/episodes.py": "reads tasks/pick/<name>.yaml of a fixed list",
    "harness/writes.py": "the temp file .<target name>.<random>.tmp beside an already safe target",
}


def test_every_output_path_from_a_name_goes_through_the_safe_name_function() -> None:
    offenders = []
    for path in sorted((ROOT / "harness").rglob("*.py")):
        relative = str(path.relative_to(ROOT))
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if NAME_PATH.search(line) and relative not in ALLOWED:
                offenders.append(f"{relative}:{number}: {line.strip()}")
    assert not offenders, "paths built from names outside safe_file_name:\n" + "\n".join(offenders)


# -- limits ------------------------------------------------------------------------------------


def test_a_long_settle_is_interrupted_at_the_deadline() -> None:
    """Issue 26 class 6: one mj_step call of 200k steps could not be interrupted (a 4 s limit
    gave a 32 s episode). Scene.step now checks the deadline between chunks."""
    from harness.config import PhysicsConfig
    from harness.errors import EpisodeTimeoutError
    from harness.sim.budget import episode_budget
    from harness.sim.scene import Scene

    scene = Scene.build("fr3", [], PhysicsConfig())
    start = time.perf_counter()
    with pytest.raises(EpisodeTimeoutError, match="wall-clock limit"), episode_budget(0.3, 10**9):
        signal.setitimer(signal.ITIMER_REAL, 0)  # the alarm is off: only the step checks count
        scene.step(10**8)
    assert time.perf_counter() - start < 3.0


@pytest.mark.slow
def test_the_pool_kills_a_worker_past_its_limit_and_loses_nothing_else(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 26 class 6: the pool had no per-episode kill. An episode hangs in a way neither
    the deadline check nor SIGALRM reaches (SIGALRM blocked, sleeping); its worker is killed
    past limit + grace, its row is ``timeout`` and the other episodes' rows are all there.

    The hanging episodes are the two of a point with a 1 s limit (killed 3 s after they start,
    not at the 62 s of the 60 s limit the honest episodes keep); they run first, so the honest
    ones run on the workers started after the kills."""
    from harness.config import load_sweep
    from harness.runs import executors
    from harness.runs.expansion import expand
    from harness.runs.sweep import run_sweep

    monkeypatch.setattr(executors, "KILL_GRACE_S", 2.0)
    sweep = write_yaml(
        tmp_path / "s.yaml",
        sweep_data(episodes_per_point=2, axes={"limits.wall_time_s": [1.0, 60.0]}),
    )
    episodes = expand(load_sweep(sweep), sweep)
    victims = [e.resolved_id for e in episodes if e.task.limits.wall_time_s == 1.0]
    assert len(victims) == 2 and episodes[0].resolved_id in victims
    faults.install(monkeypatch, hang=tuple(victims))
    start = time.monotonic()
    outcome = run_sweep(sweep, out=tmp_path / "run", backend="process", workers=1, progress=False)
    assert time.monotonic() - start < 400  # the victims are killed at 3 s each, not never
    rows = {row["episode_id"]: row for row in _jsonl(outcome.run_dir)}
    assert sorted(rows) == sorted(e.resolved_id for e in episodes)
    for victim in victims:
        assert rows[victim]["failure_reason"] == "timeout"
        assert "was killed" in rows[victim]["error_message"]
    others = [row for key, row in rows.items() if key not in victims]
    assert len(others) == 2
    assert all(row["failure_reason"] not in ("error", "timeout") for row in others), others


def _jsonl(run_dir: Path) -> list[dict]:
    import json

    lines = (run_dir / "episodes.jsonl").read_text(encoding="utf-8").splitlines()
    return [json.loads(line) for line in lines if line.strip()]


@pytest.mark.slow
def test_sigterm_stops_a_sweep_like_ctrl_c(tmp_path: Path) -> None:
    """Issue 26 class 9: SIGTERM killed the driver at once; orphaned workers printed BrokenPipe
    tracebacks. Now it stops like Ctrl-C: exit 130, finished rows kept, no traceback."""
    sweep = write_yaml(tmp_path / "s.yaml", sweep_data(episodes_per_point=200))
    run_dir = tmp_path / "run"
    driver = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "harness.cli",
            "sweep",
            str(sweep),
            "--out",
            str(run_dir),
            "--workers",
            "1",
            "--no-progress",
        ],
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    jsonl = run_dir / "episodes.jsonl"
    end = time.monotonic() + 180
    while time.monotonic() < end and not (jsonl.is_file() and jsonl.stat().st_size):
        time.sleep(0.2)
    driver.send_signal(signal.SIGTERM)
    _, err = driver.communicate(timeout=120)
    assert driver.returncode == 130, err
    assert "Traceback" not in err and "BrokenPipe" not in err, err
    time.sleep(1.0)  # an orphaned worker would write its traceback now
    assert 1 <= len(_jsonl(run_dir)) < 200


# -- writes (issue 37): special files, planted links, foreign folders, edited inputs ----------
#
# Every command writes under one rule (``harness/writes.py``): a path that exists and is not a
# regular file is refused, no symlink inside a run or tune directory is followed, a folder that
# holds files but no run is never written into, and a resume refuses edited inputs. Each case:
# one ``error:`` line, non-zero exit, and ``kept`` checks the special file, the link's target or
# the user's file is as it was.


@dataclass(frozen=True)
class WriteCase(Case):
    kept: Callable[[Path], None] | None = None  # asserts what must be untouched


def _victim(work: Path) -> Path:
    path = work.parent / "victim.txt"  # written by the test before the build
    return path


def _victim_intact(work: Path) -> None:
    assert _victim(work).read_text(encoding="utf-8") == VICTIM_TEXT


def _still(kind: Callable[[int], bool], path: str) -> Callable[[Path], None]:
    def check(work: Path) -> None:
        assert kind(os.lstat(path.replace("WORK", str(work))).st_mode), f"{path} was replaced"

    return check


def replay_into(target: str, make: str = "") -> Callable[[Path], list[str]]:
    """``replay`` of a missing run with ``--record`` / ``--video`` at ``target`` (the output
    check runs before the run directory is read, so no episode is needed)."""

    def build(work: Path) -> list[str]:
        path = Path(target.replace("WORK", str(work)))
        if make == "fifo":
            os.mkfifo(path)
        elif make == "poster link":
            path.with_suffix(".png").symlink_to(_victim(work))
        elif make == "link":
            path.symlink_to(_victim(work))
        flag = "--video" if path.suffix == ".mp4" else "--record"
        return ["replay", str(work / "norun"), "x", flag, str(path)]

    return build


def user_folder(command: str, file: str) -> Callable[[Path], list[str]]:
    """``run`` / ``sweep`` with ``--out`` a folder of the user holding ``file`` but no run."""

    def build(work: Path) -> list[str]:
        out = work / "mine"
        out.mkdir()
        (out / file).write_text(VICTIM_TEXT, encoding="utf-8")
        if command == "run":
            return ["run", str(FR3), "--episodes", "1", "--record", "none", "--out", str(out)]
        sweep = write_yaml(work / "s.yaml", sweep_data())
        return ["sweep", str(sweep), "--out", str(out), "--no-progress"]

    return build


def _user_file_intact(file: str) -> Callable[[Path], None]:
    def check(work: Path) -> None:
        assert (work / "mine" / file).read_text(encoding="utf-8") == VICTIM_TEXT
        assert sorted(os.listdir(work / "mine")) == [file], "the run wrote into the folder"

    return check


def made_run(work: Path, mesh: Path | None = None) -> Path:
    """A run directory as ``harness sweep`` creates it (``RunDir.create``), without episodes:
    its task loads ``mesh`` (a copy of the cube in ``work``), hashed into ``inputs.sha256``."""
    from harness.config import load_sweep
    from harness.files import recording_reads
    from harness.runs.expansion import load_sweep_tasks
    from harness.runs.preflight import check_tasks
    from harness.runs.rundir import RunDir

    mesh = mesh or work / "cube.obj"
    mesh.write_bytes(CUBE_OBJ.read_bytes())
    task = write_yaml(work / "t.yaml", task_data(mesh=str(mesh)))
    sweep_path = write_yaml(work / "s.yaml", sweep_data(tasks=[str(task)]))
    sweep = load_sweep(sweep_path)
    tasks = load_sweep_tasks(sweep, sweep_path)
    with recording_reads() as inputs:
        check_tasks(tasks)
    run = RunDir(work / "run")
    run.create(sweep, tasks, taken="taken", inputs=inputs)
    run.lock.release()
    return run.path


def resume_after_mesh_edit(work: Path) -> list[str]:
    run_dir = made_run(work)
    assert str((work / "cube.obj").resolve()) in (run_dir / "inputs.sha256").read_text()
    with open(work / "cube.obj", "a", encoding="utf-8") as handle:
        handle.write("# edited\n")
    return ["sweep", "--resume", str(run_dir), "--no-progress"]


def resume_with_other_size(work: Path) -> list[str]:
    return ["sweep", "--resume", str(made_run(work)), "--episodes-per-point", "3"]


def resume_with_fifo(name: str) -> Callable[[Path], list[str]]:
    """``--resume`` of a run with a FIFO where it writes (refused before any episode, not at
    the write hours later, which would block or fail)."""

    def build(work: Path) -> list[str]:
        run_dir = made_run(work)
        (run_dir / name).parent.mkdir(exist_ok=True)
        os.mkfifo(run_dir / name)
        return ["sweep", "--resume", str(run_dir), "--no-progress"]

    return build


def tune_dir_with(planted: str) -> Callable[[Path], list[str]]:
    """``tune --analyse`` of a tune directory with a planted link or FIFO (refused before
    anything is read or decided)."""

    def build(work: Path) -> list[str]:
        out = work / "t"
        (out / "tune" / "heatmaps").mkdir(parents=True)
        (out / "tune.json").write_text("{}", encoding="utf-8")
        path = out / planted
        if path.is_dir():
            shutil.rmtree(path)
            path.symlink_to(work, target_is_directory=True)
        else:
            path.unlink(missing_ok=True)
            if planted.endswith("fifo"):
                os.mkfifo(path)
            else:
                path.symlink_to(_victim(work))
        return ["tune", "--analyse", str(out)]

    return build


WRITE_CASES = [
    WriteCase(
        "replay --record /dev/full",
        replay_into("/dev/full"),
        "is a device",
        False,
        _still(stat.S_ISCHR, "/dev/full"),
    ),
    WriteCase(
        "replay --record a FIFO",
        replay_into("WORK/f.rrd", "fifo"),
        "is a FIFO",
        kept=_still(stat.S_ISFIFO, "WORK/f.rrd"),
    ),
    WriteCase(
        "replay --record a link",
        replay_into("WORK/r.rrd", "link"),
        "is a symlink",
        kept=_victim_intact,
    ),
    WriteCase(
        "replay --video poster link",
        replay_into("WORK/clip.mp4", "poster link"),
        "clip.png: is a symlink",
        kept=_victim_intact,
    ),
    WriteCase(
        "run --out a user's folder",
        user_folder("run", "report.md"),
        "is not empty and holds no run",
        kept=_user_file_intact("report.md"),
    ),
    WriteCase(
        "sweep --out foreign episodes.jsonl",
        user_folder("sweep", "episodes.jsonl"),
        "holds no run (no sweep.yaml; it holds episodes.jsonl)",
        kept=_user_file_intact("episodes.jsonl"),
    ),
    WriteCase("resume after a mesh edit", resume_after_mesh_edit, "cube.obj: changed since"),
    WriteCase(
        "resume --episodes-per-point 3",
        resume_with_other_size,
        "--episodes-per-point 3 with --resume",
    ),
    WriteCase(
        "resume with a FIFO summary.csv",
        resume_with_fifo("summary.csv"),
        "summary.csv: is a FIFO",
        kept=_still(stat.S_ISFIFO, "WORK/run/summary.csv"),
    ),
    WriteCase(
        "resume with a FIFO recording",
        resume_with_fifo("episodes/e.rrd"),
        "e.rrd: is a FIFO",
        kept=_still(stat.S_ISFIFO, "WORK/run/episodes/e.rrd"),
    ),
    WriteCase("tune/ link", tune_dir_with("tune"), "is a symlink", kept=_victim_intact),
    WriteCase(
        "tuned.yaml link", tune_dir_with("tune/tuned.yaml"), "is a symlink", kept=_victim_intact
    ),
    WriteCase(
        "heatmap link",
        tune_dir_with("tune/heatmaps/fr3_left_cube.png"),
        "is a symlink",
        kept=_victim_intact,
    ),
    WriteCase("tune.json link", tune_dir_with("tune.json"), "is a symlink", kept=_victim_intact),
    WriteCase("tune/race.csv fifo", tune_dir_with("tune/race.csv.fifo"), "FIFO"),
]


@pytest.mark.parametrize("case", WRITE_CASES, ids=[case.name for case in WRITE_CASES])
def test_adversarial_output_is_refused_and_left_alone(
    case: WriteCase, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    work = tmp_path / "work"
    work.mkdir()
    (tmp_path / "victim.txt").write_text(VICTIM_TEXT, encoding="utf-8")
    argv = case.build(work)
    before = snapshot(tmp_path)
    start = time.monotonic()
    code, err = run_cli(argv, capsys)
    assert time.monotonic() - start < CASE_LIMIT_S, f"{case.name}: ran past its limit"
    assert_one_line_refusal(code, err, case, work)
    outside = [p for p in snapshot(tmp_path) if p not in before and not p.startswith(str(work))]
    assert not outside, f"{case.name}: wrote outside its folder: {outside}"
    _victim_intact(work)
    if case.kept is not None:
        case.kept(work)


@pytest.mark.parametrize("planted", ["grasp_audit", "grasp_audit/audit.csv", "grasp_audit/x.npy"])
def test_grasps_audit_refuses_planted_links(
    planted: str, finished_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 37: ``grasps audit`` wrote through links in ``grasp_audit/`` (``audit.csv``, a
    ``<object>_cleaned.npy``) and into the target of a ``grasp_audit`` link."""
    run_dir = copy_run(finished_run, tmp_path)
    victim = tmp_path / "victim.txt"
    victim.write_text(VICTIM_TEXT, encoding="utf-8")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    path = run_dir / planted
    path.parent.mkdir(exist_ok=True)
    path.symlink_to(elsewhere if planted == "grasp_audit" else victim)
    code, err = run_cli(["grasps", "audit", str(run_dir), "--min-trials", "1"], capsys)
    errors = [line for line in err.splitlines() if line.startswith("error: ")]
    assert code == 2 and len(errors) == 1 and "Traceback" not in err, err
    assert f"{path}: is a symlink" in errors[0], errors[0]
    assert victim.read_text(encoding="utf-8") == VICTIM_TEXT
    assert not list(elsewhere.iterdir())


@pytest.fixture
def locked_run(tmp_path: Path) -> Iterator[tuple[Path, int]]:
    """A run directory whose lock another process holds (as a running sweep does)."""
    work = tmp_path / "work"
    work.mkdir()
    run_dir = made_run(work)
    holder = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import fcntl, sys, time\n"
            "h = open(sys.argv[1], 'a+'); fcntl.flock(h, fcntl.LOCK_EX)\n"
            "h.seek(0); h.truncate(); h.write(f'harness pid {__import__(\"os\").getpid()}\\n')\n"
            "h.flush(); print('locked', flush=True); time.sleep(120)",
            str(run_dir / ".lock"),
        ],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "locked"
        yield run_dir, holder.pid
    finally:
        holder.kill()
        holder.wait()


@pytest.mark.parametrize(
    "argv",
    [
        ["report", "RUN"],
        ["sweep", "--resume", "RUN", "--no-progress"],
        ["sweep", "WORK/s.yaml", "--out", "RUN", "--no-progress"],
        ["grasps", "audit", "RUN"],
    ],
    ids=["report", "second resume", "second sweep", "audit"],
)
def test_writers_honour_the_run_lock(
    argv: list[str], locked_run: tuple[Path, int], capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 37: ``report`` on a run directory locked by a running sweep wrote anyway; a second
    sweep process on it exited 0. Both now exit 2 naming the holder's pid, writing nothing."""
    run_dir, pid = locked_run
    before = sorted(os.listdir(run_dir))
    argv = [a.replace("RUN", str(run_dir)).replace("WORK", str(run_dir.parent)) for a in argv]
    code, err = run_cli(argv, capsys)
    errors = [line for line in err.splitlines() if line.startswith("error: ")]
    assert code == 2 and len(errors) == 1, err
    assert f"in use by harness pid {pid}" in errors[0], errors[0]
    assert sorted(os.listdir(run_dir)) == before


def test_tune_write_refuses_a_fifo_or_link_named_like_the_task(tmp_path: Path) -> None:
    """Issue 37: a FIFO with the task file's name blocked ``tune --write``; a link in its place
    (or the ``.diff``'s) was written through. Both are refused at once, before either file."""
    from harness.tuning.write import write_copy
    from harness.writes import OutputFileError

    source = write_yaml(tmp_path / "fr3.yaml", task_data())
    victim = tmp_path / "victim.txt"
    victim.write_text(VICTIM_TEXT, encoding="utf-8")
    keys = {"approach_filter": ["downward", 140]}
    for name, make in (("fr3.yaml", os.mkfifo), ("fr3.yaml.diff", victim.symlink_to)):
        out = tmp_path / f"out-{name}"
        out.mkdir()
        if make is os.mkfifo:
            os.mkfifo(out / name)
        else:
            (out / name).symlink_to(victim)
        start = time.monotonic()
        with pytest.raises(OutputFileError, match=re.escape(f"{out / name}: is a")):
            write_copy(source, keys, out)
        assert time.monotonic() - start < 5.0
        assert sorted(os.listdir(out)) == [name]  # neither file written
    assert victim.read_text(encoding="utf-8") == VICTIM_TEXT


def test_a_failed_export_names_its_file_and_leaves_no_temp(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 37: a full disk during the export left ``.episodes.csv.tmp`` and was reported as
    "stdout/stderr: no space". The error now names ``episodes.csv``; no temp file is left."""
    import errno

    import pandas as pd

    from harness.cli import _os_error_line
    from harness.runs.store import ResultStore

    store = ResultStore(tmp_path)
    store.append({"episode_id": "e0", "task": "t", "success": True})

    def full(self: pd.DataFrame, *args: object, **kwargs: object) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")  # pandas names no file

    monkeypatch.setattr(pd.DataFrame, "to_csv", full)
    with pytest.raises(OSError) as caught:
        store.export()
    assert _os_error_line(caught.value) == f"{tmp_path / 'episodes.csv'}: no space left on device"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["episodes.jsonl"]


def test_two_runs_in_the_same_second_get_two_directories(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 37: two ``harness run`` started in the same second shared the default run
    directory. The default name is claimed with ``mkdir`` (``-2``, ``-3``, ... when taken)."""
    from harness.runs.rundir import RunDir

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("time.strftime", lambda _: "20260101-000000")
    first, second = made_run_dirs(tmp_path, 2)
    assert first.path != second.path
    assert first.path.name == "adv-20260101-000000"
    assert second.path.name == "adv-20260101-000000-2"
    assert RunDir.default("adv").path == first.path  # claimed only at create


def made_run_dirs(tmp_path: Path, count: int) -> list:
    from harness.config import load_sweep
    from harness.runs.expansion import load_sweep_tasks
    from harness.runs.rundir import RunDir

    sweep_path = write_yaml(tmp_path / "s.yaml", sweep_data())
    sweep = load_sweep(sweep_path)
    tasks = load_sweep_tasks(sweep, sweep_path)
    runs = []
    for _ in range(count):
        run = RunDir.default(sweep.name)
        run.create(sweep, tasks, taken="taken")
        run.lock.release()
        runs.append(run)
    return runs


def test_a_second_interrupt_says_what_was_kept_and_how_to_resume(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 37: a double Ctrl-C / SIGTERM (the second one ends the command wherever it is)
    printed only "interrupted". It now names the rows kept and the resume command."""
    work = tmp_path / "work"
    work.mkdir()
    run_dir = made_run(work)  # this process's run, as a sweep's
    from harness.runs.store import ResultStore

    ResultStore(run_dir).append({"episode_id": "e0", "task": "t", "success": True})

    def second_ctrl_c(*args: object, **kwargs: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr("harness.commands.report.build_report", second_ctrl_c)
    code, err = run_cli(["report", str(run_dir)], capsys)
    assert code == 130
    assert err.strip() == (
        f"interrupted: 1 finished episode(s) are kept in {run_dir / 'episodes.jsonl'}; "
        f"continue with harness sweep --resume {run_dir}"
    )


# Calls that write a file by name: outside these modules each must go through harness.writes
# (``write_file`` / ``write_through`` / ``write_npy``: special files and links refused, temp +
# rename, failures named). A lambda's ``tmp`` is the temp file write_through made.
WRITE_CALL = re.compile(
    r"\.write_text\(|\.write_bytes\(|savefig\((?!tmp)|\.to_csv\((?!tmp|index)|"
    r"\.to_parquet\((?!tmp)|np\.savez?\((?!tmp|handle)|imwrite\((?!tmp)|get_writer\((?!tmp)|"
    r"open\([^)]*[\"'][wa]b?[\"']"
)
WRITERS_ALLOWED = {
    "harness/api.py": "the sweep YAML of harness.sweep() in its own temp folder",
    "harness/cli.py": "stdout to /dev/null after a failed flush",
    "harness/objects/coacd_process.py": "the CoACD child's exchange files in its own temp folder",
    "harness/objects/decomposition.py": "the CoACD cache: its own O_EXCL temp file + rename",
    "harness/robots/generator/generate.py": "developer tool: regenerates robots/ in the repo",
    "harness/robots/generator/collisions.py": "developer tool: regenerates robots/ in the repo",
    "harness/benchmarks/sharing.py": "bench: its own output folder",
    "harness/benchmarks/graspgen.py": "bench: a mesh in its own temp folder",
    "harness/benchmarks/estimate.py": "bench: its section times in ~/.cache/pick-harness",
}


def test_every_file_write_goes_through_the_write_rule() -> None:
    offenders = []
    for path in sorted((ROOT / "harness").rglob("*.py")):
        relative = str(path.relative_to(ROOT))
        if relative in WRITERS_ALLOWED or relative == "harness/writes.py":
            continue
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            code = line.split("#", 1)[0]
            if WRITE_CALL.search(code) and '"""' not in line and "``" not in line:
                offenders.append(f"{relative}:{number}: {line.strip()}")
    assert not offenders, "writes outside harness/writes.py:\n" + "\n".join(offenders)


# -- issue 37: names reach the terminal as text ------------------------------------------------

MARKUP_NAME = "t[/x]\x1b]0;pwned\x07\x1b[31mred"  # rich markup, an OSC title, an SGR colour


def test_the_console_shows_markup_and_control_characters_as_text() -> None:
    """One rule for every string rich prints (``SafeConsole.render_str``): a ``[/x]`` in a path
    crashed rich (MarkupError); an escape in a task name reached the terminal."""
    import io

    from rich.table import Table

    from harness.commands.console import SafeConsole, styled, visible

    out = io.StringIO()
    console = SafeConsole(file=out, force_terminal=True, width=200, markup=False)
    table = Table(title=f"run {MARKUP_NAME}")
    table.add_column("task")
    table.add_row(MARKUP_NAME)
    console.print(f"run directory: {MARKUP_NAME} :smile:")
    console.print(table)
    console.print(styled("[bold]{name}[/]: ok", name=MARKUP_NAME))
    text = re.sub("\x1b\\[[0-9;]*m", "", out.getvalue())  # rich's own styling (a terminal)
    shown = "t[/x]\\x1b]0;pwned\\x07\\x1b[31mred"
    assert text.count(shown) == 4 and ":smile:" in text
    assert "\x1b" not in text and "\x07" not in text
    assert visible("a\u202eb\tc\n") == "a\\u202eb\tc\n"


@pytest.fixture(scope="module")
def markup_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    """``harness run`` of a task named ``t[/x]<OSC><SGR>red`` whose object is ``o[/y]``, into
    ``--out .../r[/x]``; its stdout."""
    import io

    folder = tmp_path_factory.mktemp("markup")
    data = task_data(name="o[/y]")
    data["name"] = MARKUP_NAME
    task = write_yaml(folder / "t.yaml", data)
    run_dir = folder / "r[" / "x]"
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = cli.main(
            ["run", str(task), "--episodes", "1", "--record", "none", "--out", str(run_dir)]
        )
    assert code == 0
    return run_dir, out.getvalue()


def test_run_prints_markup_names_and_paths_as_text(markup_run: tuple[Path, str]) -> None:
    run_dir, text = markup_run
    assert f"run directory: {run_dir}" in text
    assert "t[/x]\\x1b]0;pwned\\x07\\x1b[31mred" in text
    assert "\x1b" not in text and "\x07" not in text  # not a terminal: no escapes at all


def test_report_and_validate_print_markup_names_as_text(
    markup_run: tuple[Path, str], capsys: pytest.CaptureFixture[str]
) -> None:
    run_dir, _ = markup_run
    assert cli.main(["report", str(run_dir), "--no-videos"]) == 0
    out = capsys.readouterr().out
    assert f"success per point ({run_dir})" in out and f"{run_dir}/report.html" in out
    assert cli.main(["validate", str(run_dir.parent.parent / "t.yaml")]) == 0
    out = capsys.readouterr().out
    assert "\\x1b]0;pwned\\x07" in out and "\x1b" not in out


def test_an_error_line_shows_control_characters(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    missing = tmp_path / "a\x1b]0;pwned\x07.yaml"
    code, err = run_cli(["validate", str(missing)], capsys)
    assert code == 1 and "\x1b" not in err and "a\\x1b]0;pwned\\x07.yaml" in err, err


# -- issue 37: offscreen GL and the viewer's display --------------------------------------------


def test_no_offscreen_gl_is_one_warning_and_no_videos(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``sweep --videos`` with MUJOCO_GL unset and no display aborted natively (GLFW, libc++
    "recursive initialization") after the rows and before the report. The backend is now tried
    in a child process first; here GLFW without a display cannot render, so: one warning line,
    no videos, and the command goes on."""
    from harness.commands.console import videos_possible
    from harness.viz.render import offscreen_gl_problem

    monkeypatch.setenv("MUJOCO_GL", "glfw")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    offscreen_gl_problem.cache_clear()
    try:
        assert videos_possible(True) is False
    finally:
        offscreen_gl_problem.cache_clear()
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("warning: videos skipped: MUJOCO_GL=glfw")
    assert videos_possible(False) is False


def fake_viewer(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A ``rerun`` on PATH that fails as the real one does without a display (multi-line)."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    viewer = bin_dir / "rerun"
    viewer.write_text(
        "#!/bin/sh\necho 'INFO telemetry' >&2\necho 'WARN docker' >&2\n"
        "echo 'Error: winit EventLoopError: Failed to open connection to X server' >&2\nexit 1\n",
        encoding="utf-8",
    )
    viewer.chmod(0o755)
    monkeypatch.setenv("PATH", f"{bin_dir}{os.pathsep}{os.environ['PATH']}")


@pytest.mark.parametrize(
    "variable, value",
    [("DISPLAY", ":97"), ("DISPLAY", "nohost.invalid:0"), ("WAYLAND_DISPLAY", "w-9")],
)
def test_view_on_a_dead_display_is_one_line_with_the_web_hint(
    variable: str,
    value: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    if variable == "DISPLAY" and Path("/tmp/.X11-unix/X97").exists():
        pytest.skip("an X server :97 runs here")
    fake_viewer(tmp_path, monkeypatch)
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))
    monkeypatch.setenv(variable, value)
    recording = tmp_path / "x.rrd"
    recording.write_bytes(b"RRF2")
    code, err = run_cli(["view", str(recording)], capsys)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1, err
    assert f"{variable}={value}: no display server answers" in lines[0]
    assert f"rerun --bind 127.0.0.1 --web-viewer {recording}" in lines[0]


def test_a_failing_viewer_is_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from harness.commands import view

    fake_viewer(tmp_path, monkeypatch)
    monkeypatch.setenv("DISPLAY", ":0")
    monkeypatch.setattr(view, "dead_display", lambda: None)  # as if a server answered
    recording = tmp_path / "x.rrd"
    recording.write_bytes(b"RRF2")
    code, err = run_cli(["view", str(recording)], capsys)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1, err
    assert "the Rerun viewer failed (Error: winit EventLoopError" in lines[0]
    assert "--web-viewer" in lines[0]


@pytest.mark.slow
def test_sweep_videos_without_offscreen_gl_keeps_rows_and_report(tmp_path: Path) -> None:
    """Issue 37: ``sweep --videos`` where MuJoCo falls back to GLFW without a display aborted
    natively in libc++ after the rows, and no report was written."""
    sweep = write_yaml(tmp_path / "s.yaml", sweep_data())
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    argv = ["sweep", str(sweep), "--videos", "--out", str(tmp_path / "run"), "--workers", "1"]
    result = subprocess.run(
        [sys.executable, "-m", "harness.cli", *argv, "--no-progress"],
        env={**env, "PYTHONPATH": str(ROOT), "MUJOCO_GL": "glfw"},
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    assert "warning: videos skipped: MUJOCO_GL=glfw" in result.stderr
    assert "Traceback" not in result.stderr and "libc++abi" not in result.stderr
    assert (tmp_path / "run" / "report.html").is_file()
    assert len(_jsonl(tmp_path / "run")) == 1
