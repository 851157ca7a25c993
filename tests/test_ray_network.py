"""A local Ray listens on loopback only and does not outlive a killed driver (issue 26, class 9).

One real ``harness sweep --backend ray`` in a child process: while it runs, every listening
socket of its process tree is read (psutil); then the driver is killed with SIGKILL and every
process of that tree must be gone within seconds (``harness.runs.ray_local``'s watchdog).
"""

from __future__ import annotations

import glob
import ipaddress
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
FR3 = ROOT / "tasks" / "pick" / "fr3.yaml"

pytestmark = [pytest.mark.slow, pytest.mark.ray]


def _wait(predicate, timeout_s: float, what: str) -> None:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if predicate():
            return
        time.sleep(0.2)
    raise AssertionError(f"timed out waiting for {what}")


def _ipv4(ip: str) -> str:
    address = ipaddress.ip_address(ip)
    mapped = getattr(address, "ipv4_mapped", None)
    return str(mapped or address)


RAY_TEMP = os.path.join(tempfile.gettempdir(), "harness-ray-*")


def test_a_local_ray_listens_on_loopback_and_dies_with_its_driver(tmp_path: Path) -> None:
    pytest.importorskip("ray")
    psutil = pytest.importorskip("psutil")
    sweep = {"name": "ray-net", "tasks": [str(FR3)], "episodes_per_point": 400, "record": "none"}
    sweep_path = tmp_path / "sweep.yaml"
    sweep_path.write_text(yaml.safe_dump(sweep), encoding="utf-8")
    run_dir = tmp_path / "run"
    before = set(glob.glob(RAY_TEMP))
    driver = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "harness.cli",
            "sweep",
            str(sweep_path),
            "--out",
            str(run_dir),
            "--backend",
            "ray",
            "--workers",
            "1",
            "--no-progress",
        ],
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    try:
        jsonl = run_dir / "episodes.jsonl"
        _wait(lambda: jsonl.is_file() and jsonl.stat().st_size > 0, 240, "the first Ray row")
        tree = psutil.Process(driver.pid).children(recursive=True)
        names = {p.name() for p in tree if p.is_running()}
        assert any("gcs_server" in n for n in names) and any("raylet" in n for n in names), names
        listening = []
        for process in [psutil.Process(driver.pid), *tree]:
            try:
                connections = process.net_connections(kind="inet")
            except psutil.Error:
                continue
            listening += [
                (process.name(), c.laddr.ip, c.laddr.port)
                for c in connections
                if c.status == psutil.CONN_LISTEN
            ]
        assert len(listening) >= 3, listening  # gcs_server, raylet, core workers
        # gRPC listens on IPv6 sockets: ::ffff:127.0.0.1 is 127.0.0.1 (IPv4-mapped), not "::".
        assert all(_ipv4(ip) == "127.0.0.1" for _, ip, _ in listening), listening
        os.kill(driver.pid, signal.SIGKILL)
        driver.wait(timeout=10)

        def all_gone() -> bool:
            return not [p for p in tree if p.is_running() and p.status() != psutil.STATUS_ZOMBIE]

        _wait(all_gone, 30, "the Ray processes to end after the driver's SIGKILL")
        # Its session files (a harness-ray-* temp folder, not /tmp/ray/session_*) go too.
        _wait(lambda: not set(glob.glob(RAY_TEMP)) - before, 30, "the Ray temp folder to go")
    finally:
        if driver.poll() is None:
            driver.kill()
