"""A local Ray for ``--backend ray``: listening on loopback only, and gone when the run is gone.

Network: Ray 2.60 binds its gRPC servers (gcs_server, raylet, core workers) to every interface
on Linux and has no bind option (``ray.init(_node_ip_address="127.0.0.1")`` is turned back into
the node's address by ``services.resolve_ip_for_localhost``; binding to the node address
instead of 0.0.0.0 arrived later, ray-project/ray#59852). Ray's own local-only mode, the one it
uses on macOS and Windows, takes the loopback address as the node address, and every server
binds to the node address: ``ray_constants.ENABLE_RAY_CLUSTER`` false, read from
``RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER`` (``ray/_private/ray_constants.py``, used by
``services.get_node_ip_address``). ``local_ray`` sets both for a local start only; ``--address``
connects to a cluster the user runs and configures.

Lifetime: a kill -9 of the driver left gcs_server and a raylet running (one still listening).
``local_ray`` starts a watchdog process that follows the driver's process tree and kills what
is left of it once the driver is gone (``python -m harness.runs.ray_local PID``).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

LOCAL_ONLY_ENV = "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"
WATCH_EVERY_S = 0.5


@contextlib.contextmanager
def local_ray(workers: int) -> Iterator[Any]:
    """``ray``, initialised as a local cluster on 127.0.0.1 with ``workers`` CPUs; shut down
    (and the environment restored) on exit. Its session files go to a temp folder of this
    process (``_temp_dir``), removed on exit, or by the watchdog after a kill -9, instead of
    ``/tmp/ray/session_*`` left behind for ever."""
    previous = os.environ.get(LOCAL_ONLY_ENV)
    os.environ[LOCAL_ONLY_ENV] = "0"  # inherited by gcs_server, raylet and the workers
    import ray
    from ray._private import ray_constants

    saved = ray_constants.ENABLE_RAY_CLUSTER
    ray_constants.ENABLE_RAY_CLUSTER = False  # read at import: an earlier import missed it
    watchdog: subprocess.Popen[bytes] | None = None
    temp_dir = tempfile.mkdtemp(prefix="harness-ray-")  # short: Ray's socket paths must fit
    try:
        ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False, _temp_dir=temp_dir)
        watchdog = start_watchdog(os.getpid(), temp_dir)
        yield ray
    finally:
        try:
            ray.shutdown()
        finally:
            if watchdog is not None:
                watchdog.terminate()
                watchdog.wait(timeout=10)
            shutil.rmtree(temp_dir, ignore_errors=True)
            ray_constants.ENABLE_RAY_CLUSTER = saved
            if previous is None:
                os.environ.pop(LOCAL_ONLY_ENV, None)
            else:
                os.environ[LOCAL_ONLY_ENV] = previous


def start_watchdog(driver_pid: int, temp_dir: str = "") -> subprocess.Popen[bytes]:
    """A process that kills the driver's leftover process tree once the driver dies (and
    removes its Ray ``temp_dir``)."""
    return subprocess.Popen(
        [sys.executable, "-m", "harness.runs.ray_local", str(driver_pid), temp_dir],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,  # a Ctrl-C to the terminal's group leaves it to the driver
    )


def watch(driver_pid: int, temp_dir: str = "") -> None:
    """Follow ``driver_pid``'s descendants; when it is gone, SIGKILL those still running and
    remove ``temp_dir`` (the driver's Ray session files)."""
    import psutil

    me = os.getpid()
    try:
        driver = psutil.Process(driver_pid)
    except psutil.NoSuchProcess:
        return
    known: dict[int, psutil.Process] = {}
    while True:
        try:
            if not driver.is_running() or driver.status() == psutil.STATUS_ZOMBIE:
                break
            for child in driver.children(recursive=True):
                if child.pid != me:
                    known.setdefault(child.pid, child)
        except psutil.NoSuchProcess:
            break
        time.sleep(WATCH_EVERY_S)
    leftovers = []
    for process in known.values():
        with contextlib.suppress(psutil.Error):
            if process.is_running():  # same pid *and* start time: not a reused pid
                leftovers += [process, *process.children(recursive=True)]
    for process in leftovers:
        with contextlib.suppress(psutil.Error):
            process.kill()
    if temp_dir and Path(temp_dir).name.startswith("harness-ray-"):
        psutil.wait_procs(leftovers, timeout=10)
        shutil.rmtree(temp_dir, ignore_errors=True)


if __name__ == "__main__":
    watch(int(sys.argv[1]), sys.argv[2] if len(sys.argv) > 2 else "")
