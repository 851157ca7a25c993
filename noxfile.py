"""Sessions: ``tests`` (the CI command), ``demo`` (the main job), ``benchmark``, ``lint``.

Each session installs the project from its own files. uv is used when present (fast, cached:
the sessions' environments share its files); otherwise virtualenv + pip, chosen here so that nox
prints no "uv binary not found" warning.
"""

from __future__ import annotations

import importlib.util
import os
import shutil

import nox


def venv_backend() -> str:
    """``uv`` when nox can use one (``$UV``, on PATH, or the uv package beside nox: nox's own
    ``find_uv``), else ``virtualenv``."""
    try:
        from nox.virtualenv import find_uv  # nox >= 2024.4

        has_uv = find_uv()[0]
    except (ImportError, OSError):
        has_uv = shutil.which("uv") is not None or importlib.util.find_spec("uv") is not None
    return "uv" if has_uv else "virtualenv"


nox.options.default_venv_backend = venv_backend()
nox.options.reuse_venv = "yes"
nox.options.sessions = ["lint", "tests"]

PYTHON = "3.11"
# Bytecode compiled at install (uv: UV_COMPILE_BYTECODE; pip does it anyway) and for the
# project's own modules: where the environment sets PYTHONDONTWRITEBYTECODE=1 (as these build
# machines do) no .pyc is ever written on import, so every new interpreter (each command, each
# worker process, each test subprocess) compiled its imports again, ~3-4 s a process
# (docs/performance.md). Reading .pyc files is not affected by the variable.
COMPILE_ENV = {"UV_COMPILE_BYTECODE": "1"}
# Offscreen MuJoCo rendering without a display: EGL on Mesa, unless the user chose otherwise.
RENDER_ENV = {"MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}


# Compiles the project's modules, and once per venv (a marker file in it) the installed packages
# (a venv installed before without bytecode); later installs compile their own (COMPILE_ENV).
COMPILE = """
import compileall, os, sys, sysconfig
marker = os.path.join(sys.prefix, ".harness-bytecode")
if not os.path.exists(marker):
    compileall.compile_dir(sysconfig.get_paths()["purelib"], quiet=1, workers=0)
    open(marker, "w").close()
compileall.compile_dir("harness", quiet=1, workers=0)
"""


def _install(session: nox.Session, *args: str) -> None:
    """Install ``args`` with bytecode, and compile the project's modules (``harness``)."""
    session.install(*args, env=COMPILE_ENV)
    session.run_install("python", "-c", COMPILE, silent=True)


@nox.session(python=PYTHON)
def tests(session: nox.Session) -> None:
    """Run the test suite. Pass pytest arguments after ``--`` (e.g. ``-m "not slow"``; they
    replace the defaults, so ``-- -q`` runs it in one process).

    By default in one pytest process per core, at most four (pytest-xdist): most tests are one
    Python thread, so on the 2-core build machine the suite took 7 min 17 s this way against
    12-13 min in one process (2026-11-28 evening)."""
    _install(session, "-e", ".[dev,ray]")
    args = session.posargs or ["-q", "-n", "auto", "--maxprocesses", "4"]
    session.run("pytest", *args, env=RENDER_ENV)


@nox.session(python=PYTHON)
def demo(session: nox.Session) -> None:
    """The main job: the default sweep over the three robots (report, videos, recording), then
    a template tune of the FR3 arm's approach x facing filters over the nine default objects
    (screening maps, a pooled race on fresh seeds, exceptions per object, tuned.yaml).

    Arguments after ``--`` replace the sweep's (the tune is then skipped)."""
    _install(session, "-e", ".")
    if session.posargs:
        session.run("harness", "sweep", *session.posargs, env=RENDER_ENV)
        return
    session.run("harness", "sweep", "tasks/sweeps/demo.yaml", "--videos", env=RENDER_ENV)
    # The template tune: one filter setting for the FR3 arm over the nine default objects
    # (docs/template-tune.md). --directions canonical and a small grid keep it minutes on 2 cores.
    tune = ["tasks/sweeps/demo_template.yaml", "--template", "--directions", "canonical",
            "--step", "45", "--bands", "0", "--episodes", "4", "--top", "2", "--block", "4",
            "--max-seeds", "8", "--exception-seeds", "20"]  # fmt: skip
    session.run("harness", "tune", *tune, env=RENDER_ENV)


@nox.session(python=PYTHON)
def benchmark(session: nox.Session) -> None:
    """Measure speed (``harness bench``); writes reports/bench.json."""
    _install(session, "-e", ".")
    args = session.posargs or ["--json", "reports/bench.json"]
    session.run("harness", "bench", *args, env=RENDER_ENV)


@nox.session(python=PYTHON)
def lint(session: nox.Session) -> None:
    """ruff check, ruff format --check, and pyright (basic mode, pyrightconfig.json)."""
    _install(session, "-e", ".[dev,ray]", "pyright[nodejs]>=1.1.400")
    session.run("ruff", "check", "harness", "tests", "robots", "noxfile.py")
    session.run("ruff", "format", "--check", "harness", "tests", "robots", "noxfile.py")
    python = os.path.join(session.virtualenv.location, "bin", "python")
    session.run("pyright", "--pythonpath", python)
