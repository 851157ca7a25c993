"""Physics steps as a device-side loop (harness.engines.mjwarp.graph_loop): the counter runs the
step exactly the asked number of times, and the switch reads its environment variable. On
Warp's CPU device ``capture_while`` runs eagerly (the host reads the counter every turn), so
this pins the count logic; the captured WHILE node is exercised on a GPU
(``HARNESS_GRAPH_LOOP=1``, docs/engines.md). Skipped without the 'gpu' extra."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

HAS_WARP = importlib.util.find_spec("warp") is not None
pytestmark = [
    pytest.mark.gpu,
    pytest.mark.skipif(not HAS_WARP, reason="needs the 'gpu' extra (pip install .[gpu])"),
]

if HAS_WARP:
    import warp as wp

    @wp.kernel
    def add_one(total: wp.array(dtype=wp.int32)):  # type: ignore[valid-type]
        total[0] = total[0] + 1


@pytest.mark.parametrize("times", [1, 3, 136])
def test_the_loop_runs_its_step_the_asked_number_of_times(times: int) -> None:
    from harness.engines.mjwarp.graph_loop import run_loop

    total = wp.zeros(1, dtype=wp.int32, device="cpu")
    left = wp.zeros(1, dtype=wp.int32, device="cpu")
    calls = []

    def step() -> None:
        calls.append(1)
        wp.launch(add_one, dim=1, inputs=[total], device="cpu")

    run_loop("cpu", step, times, left)
    assert len(calls) == times
    assert int(total.numpy()[0]) == times
    assert np.array_equal(left.numpy(), [0])  # counted down to the end


def test_the_loop_is_off_unless_asked(monkeypatch: pytest.MonkeyPatch) -> None:
    from harness.engines.mjwarp.graph_loop import LOOP_ENV, graph_loop

    monkeypatch.delenv(LOOP_ENV, raising=False)
    assert not graph_loop()
    monkeypatch.setenv(LOOP_ENV, "0")
    assert not graph_loop()
    monkeypatch.setenv(LOOP_ENV, "1")
    assert graph_loop()
