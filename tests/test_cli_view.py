"""``harness view``: without a display it explains how to open the recording."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from harness.cli import main
from harness.commands.view import open_instructions


def test_view_without_display_prints_instructions(tmp_path: Path, monkeypatch, capsys):
    recording = tmp_path / "x.rrd"
    recording.write_bytes(b"RRF2")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["view", str(recording)]) == 0
    out = capsys.readouterr().out
    assert "no display" in out
    # Commands that run as printed: this interpreter's `-m rerun` (no bare `rerun` that a venv
    # under nox leaves off PATH), the full path of the file, and the browser option.
    assert f"{sys.executable} -m rerun {recording}" in out
    assert f"--bind 127.0.0.1 --web-viewer {recording}" in out
    assert "\n  - on a machine with a display: rerun " not in out


def test_view_names_the_viewer_binary_of_this_environment(tmp_path: Path) -> None:
    binary = tmp_path / "bin" / "rerun"
    binary.parent.mkdir()
    binary.write_text("#!/bin/sh\n", encoding="utf-8")
    binary.chmod(0o755)
    lines = open_instructions(tmp_path / "x.rrd", str(binary))
    assert f"  - on a machine with a display: {binary} {tmp_path / 'x.rrd'}" in lines
    assert not any("pip install" in line for line in lines)
    missing = open_instructions(tmp_path / "x.rrd", None)
    assert any(f"{sys.executable} -m pip install 'rerun-sdk==0.41.*'" in line for line in missing)


def test_view_a_run_directory_opens_its_recording(tmp_path: Path, monkeypatch, capsys):
    (tmp_path / "recording.rrd").write_bytes(b"RRF2")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["view", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert f"{tmp_path / 'recording.rrd'}" in out
    assert "--bind 127.0.0.1" in out  # the viewer's server never listens on every interface


def test_view_missing_file_is_one_line_error(tmp_path: Path, capsys):
    assert main(["view", str(tmp_path / "missing.rrd")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "missing.rrd: no such recording" in err[0]


@pytest.mark.parametrize("argv", [["--version"]])
def test_version(argv, capsys):
    with pytest.raises(SystemExit) as info:
        main(argv)
    assert info.value.code == 0
    assert capsys.readouterr().out.startswith("pick-harness ")


@pytest.mark.parametrize("name, content", [("episodes.csv", b"a,b\n1,2\n"), ("fake.rrd", b"hello")])
def test_view_refuses_what_is_not_a_recording(tmp_path: Path, capsys, name: str, content: bytes):
    path = tmp_path / name
    path.write_bytes(content)
    assert main(["view", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not a Rerun recording" in err[0]


def test_view_refuses_etc_passwd(capsys):
    if not Path("/etc/passwd").is_file():
        pytest.skip("no /etc/passwd on this system")
    assert main(["view", "/etc/passwd"]) == 2
    assert "not a Rerun recording" in capsys.readouterr().err
