"""Device slots (harness.engines.mjwarp.slot) on Warp's CPU device: the slots of a device share
one lock, which a slot holds while it issues Warp calls; on the CPU there are no streams.
Skipped without the 'gpu' extra (Warp)."""

from __future__ import annotations

import importlib.util
import threading

import pytest

HAS_WARP = importlib.util.find_spec("warp") is not None

pytestmark = [
    pytest.mark.gpu,
    pytest.mark.skipif(not HAS_WARP, reason="needs the 'gpu' extra (pip install .[gpu])"),
]


def test_slots_of_a_device_share_one_lock_and_take_turns() -> None:
    from harness.engines.mjwarp.slot import DeviceSlot

    first, second = DeviceSlot.several("cpu", 2)
    assert first.lock is second.lock and first.stream is None and not first.cuda
    entered = threading.Event()

    def other() -> None:
        with second:
            entered.set()

    with first:
        thread = threading.Thread(target=other)
        thread.start()
        assert not entered.wait(timeout=0.2)  # the other slot waits for the lock
        first.wait()  # on the CPU: a synchronize, the lock still held on return
        assert first.lock.locked()
    thread.join(timeout=10)
    assert entered.is_set() and not first.lock.locked()
