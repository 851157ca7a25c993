"""The mjwarp engine downloads device arrays on the calling stream (harness.engines.mjwarp.host):
Warp's ``array.numpy()`` copies on the CUDA default stream, which waits for every lane stream of
the device (docs/engines.md, "The sitting of 2026-11-27 evening"), so no engine module calls it.
"""

from __future__ import annotations

import ast
from pathlib import Path

from helpers import PROJECT_ROOT

ENGINE = PROJECT_ROOT / "harness" / "engines" / "mjwarp"


def _numpy_calls(path: Path) -> list[int]:
    """Lines of ``<expr>.numpy()`` calls in ``path``."""
    tree = ast.parse(path.read_text(), filename=str(path))
    return [
        node.lineno
        for node in ast.walk(tree)
        if isinstance(node, ast.Call)
        and isinstance(node.func, ast.Attribute)
        and node.func.attr == "numpy"
        and not node.args
    ]


def test_no_engine_module_downloads_on_the_default_stream() -> None:
    """Every ``.numpy()`` of the engine's modules is in ``host.py`` (the CPU device's path of
    its downloads); the lanes, batches and steps download through ``to_host`` or
    ``to_host_all`` (the calling stream, one wait)."""
    calls = {p.name: _numpy_calls(p) for p in sorted(ENGINE.glob("*.py"))}
    assert calls["host.py"], "host.py should hold the one .numpy() (the CPU device's path)"
    offenders = {name: lines for name, lines in calls.items() if lines and name != "host.py"}
    assert offenders == {}
    for name in ("lanes.py", "batch.py", "steps.py"):
        text = (ENGINE / name).read_text()
        assert "to_host(" in text or "to_host_all(" in text, name
