"""The input manifest of a run: the sha256 of every file its tasks loaded, checked on resume.

``sweep.yaml`` holds the tasks inlined, so an edit of it is caught by its own hash
(``harness.runs.safety``); the files the tasks load (meshes, USD layers, grasp files, robot and
object YAML) are not in it. Their hashes, taken when the run is created, are kept in
``RUN_DIR/inputs.sha256`` (one ``<sha256>  <path>`` line each, the ``sha256sum`` format); a
``--resume`` whose inputs changed is refused naming the first changed file, unless ``--force``:
it would otherwise mix rows of two meshes in one table.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable
from pathlib import Path

from harness.config import ConfigError
from harness.writes import write_file

INPUTS_NAME = "inputs.sha256"
CHANGED = "resuming would mix rows of two inputs in one table (start a new run, or pass --force)"


def file_sha256(path: Path) -> str | None:
    """The sha256 of a regular file's bytes, None if it is gone or not a regular file."""
    from harness.files import RefusedFileError, open_regular

    try:
        fd = open_regular(path)
    except (OSError, RefusedFileError):
        return None
    digest = hashlib.sha256()
    with open(fd, "rb") as handle:
        for chunk in iter(lambda: handle.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def record_inputs(run_dir: Path, paths: Iterable[str]) -> Path:
    """Write ``inputs.sha256`` for ``paths`` (files inside the run directory excluded)."""
    root = run_dir.resolve()
    lines = []
    for name in sorted(set(paths)):
        path = Path(name)
        if root in path.parents:
            continue
        digest = file_sha256(path)
        if digest is not None:
            lines.append(f"{digest}  {path}\n")
    return write_file(run_dir / INPUTS_NAME, "".join(lines), root=run_dir)


def check_inputs(run_dir: Path) -> None:
    """Refuse a resume whose recorded inputs changed or are gone (a run without the manifest,
    made before it existed, is not checked)."""
    manifest = run_dir / INPUTS_NAME
    if not manifest.is_file():
        return
    from harness.files import read_capped

    text = read_capped(manifest, 16 * 1024 * 1024).decode("utf-8", errors="replace")
    for number, line in enumerate(text.splitlines(), 1):
        digest, sep, name = line.partition("  ")
        if not sep or len(digest) != 64:
            raise ConfigError(f"line {number} is not '<sha256>  <path>'", file=manifest)
        now = file_sha256(Path(name))
        if now != digest:
            what = "is gone or not a regular file" if now is None else "changed"
            raise ConfigError(f"{what} since the run was created; {CHANGED}", file=name)
