"""``--address`` of a Ray cluster, checked before ``ray.init`` sees it.

``ray.init(address="not-a-host:xx")`` raised a bare ``ValueError`` (a traceback), and an address
whose port is closed made Ray retry for about 240 s while printing multi-line logs. The address
is parsed here (``host:port``, ``[v6]:port``, an optional ``ray://`` client prefix, or Ray's
``auto`` / ``local``) and its TCP port is probed with a short timeout, so a wrong address is one
line within seconds.
"""

from __future__ import annotations

import re
import socket

from harness.errors import HarnessError

# A cluster head on the same network answers a TCP connect in milliseconds; a few seconds
# cover a slow link. Chosen, no public source.
PROBE_TIMEOUT_S = 3.0
RAY_KEYWORDS = ("auto", "local")
_HOST = re.compile(r"^(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9]([A-Za-z0-9.-]{0,251}[A-Za-z0-9])?)$")


def parse_ray_address(address: str) -> tuple[str, int] | None:
    """``(host, port)`` of ``address``; None for ``auto`` / ``local`` (Ray finds the cluster);
    ``HarnessError`` naming the flag when it is not ``host:port``."""
    text = address.strip()
    if text in RAY_KEYWORDS:
        return None
    text = text.removeprefix("ray://")
    host, sep, port_text = text.rpartition(":")
    if not sep or not _HOST.match(host):
        raise HarnessError(
            f"--address {address!r}: expected HOST:PORT (e.g. 10.0.0.5:6379), ray://HOST:PORT, "
            "auto or local"
        )
    if not port_text.isdigit() or not 1 <= int(port_text) <= 65535:
        raise HarnessError(f"--address {address!r}: port {port_text!r} is not a number in 1-65535")
    return host.strip("[]"), int(port_text)


def check_ray_address(address: str, timeout_s: float = PROBE_TIMEOUT_S) -> None:
    """Parse ``address`` and connect to its TCP port once; ``HarnessError`` (one line) when
    the host is unknown or nothing listens there within ``timeout_s``."""
    parsed = parse_ray_address(address)
    if parsed is None:
        return
    host, port = parsed
    try:
        with socket.create_connection((host, port), timeout=timeout_s):
            pass
    except socket.gaierror as exc:
        raise HarnessError(f"--address {address}: unknown host {host!r} ({exc.strerror})") from None
    except TimeoutError:
        raise HarnessError(
            f"--address {address}: no answer from {host}:{port} within {timeout_s:g} s "
            "(a firewall, or the wrong host?)"
        ) from None
    except OSError as exc:
        reason = (exc.strerror or str(exc)).lower()
        raise HarnessError(
            f"--address {address}: cannot connect to {host}:{port} ({reason}); is the Ray head "
            "running there (ray start --head --port PORT)?"
        ) from None
