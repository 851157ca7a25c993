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


def test_a_graph_launch_lets_the_other_slots_have_the_lock(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A launch that blocks on a full device queue must not hold the lock: another slot takes
    it meanwhile. The launch names the slot's stream; a graph's first launch (it is
    instantiated then) and a slot without a stream keep the lock."""
    import warp as wp

    from harness.engines.mjwarp import slot as slot_module

    lock = threading.Lock()
    stream = object()
    slot = slot_module.DeviceSlot("cpu", lock=lock, stream=stream)
    monkeypatch.setattr(slot, "_make_current", lambda: None)
    seen: list[tuple[bool, object]] = []
    other_ran = threading.Event()

    def blocking_launch(graph: object, stream: object = None) -> None:
        seen.append((lock.locked(), stream))
        if stream is not None:  # as a full queue would: the other slot gets the lock meanwhile
            thread = threading.Thread(
                target=lambda: (lock.acquire(), other_ran.set(), lock.release()),
                daemon=True,
            )
            thread.start()
            thread.join(timeout=10)

    monkeypatch.setattr(wp, "capture_launch", blocking_launch)

    class Graph:
        graph_exec: object = None

    graph = Graph()
    with slot:
        slot.launch(graph)  # first launch: instantiates, under the lock
        graph.graph_exec = object()
        slot.launch(graph)
        assert lock.locked()  # held again on return
        slot.launch(graph, times=3)  # the lock let go once for all three
    assert seen == [(True, None), (False, stream), *[(False, stream)] * 3]
    assert other_ran.is_set()
    no_stream = slot_module.DeviceSlot("cpu", lock=lock)
    with no_stream:
        no_stream.launch(graph)
    assert seen[-1] == (True, None)


def test_a_blocking_wait_lets_go_of_the_lock_while_the_driver_sleeps(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A blocking wait (the default; ``HARNESS_DEVICE_WAIT=poll`` polls): the slot records its
    event on its own stream, then waits for it in the native call with the lock let go
    (another slot takes it meanwhile), and holds the lock again, with its stream current, on
    return."""
    from types import SimpleNamespace

    from harness.engines.mjwarp import slot as slot_module

    lock = threading.Lock()
    recorded: list[object] = []
    stream = SimpleNamespace(record_event=recorded.append)
    slot = slot_module.DeviceSlot("cpu", lock=lock, stream=stream)
    made_current: list[bool] = []
    monkeypatch.setattr(slot, "_make_current", lambda: made_current.append(lock.locked()))
    other_ran = threading.Event()

    def synchronize(handle: object) -> bool:
        assert not lock.locked()
        thread = threading.Thread(
            target=lambda: (lock.acquire(), other_ran.set(), lock.release()), daemon=True
        )
        thread.start()
        thread.join(timeout=10)
        return True

    monkeypatch.setattr(
        slot_module, "_native", lambda: SimpleNamespace(wp_cuda_event_synchronize=synchronize)
    )
    event = SimpleNamespace(cuda_event=object())
    with slot:
        slot._record(event)
        slot._sync_blocking(event)
        assert lock.locked()
    assert recorded == [event] and other_ran.is_set()
    assert made_current == [True, True]  # on entering the slot, and after the wait


def test_a_mark_is_waited_for_with_the_lock_let_go() -> None:
    """``wait_mark`` (the lanes' pipelined visits) polls a mark recorded without a blocking
    event, letting go of the lock between queries (another thread takes it meanwhile), and
    holds it again on return; a slot of the CPU device has no marks (its work ran as it was
    issued)."""
    from harness.engines.mjwarp import slot as slot_module

    lock = threading.Lock()
    slot = slot_module.DeviceSlot("cpu", lock=lock)
    assert slot.mark() is None
    other_ran = threading.Event()
    other = threading.Thread(
        target=lambda: (lock.acquire(), other_ran.set(), lock.release()), daemon=True
    )

    class Mark:
        queries = 0

        @property
        def is_complete(self) -> bool:
            self.queries += 1
            if self.queries == 1:
                other.start()  # blocked until the slot lets go of the lock
                return False
            return other_ran.wait(timeout=10)

    slot._make_current = lambda: None  # type: ignore[method-assign]
    with slot:
        slot.wait_mark(None)
        slot.wait_mark(Mark())
        assert lock.locked() and other_ran.is_set()
