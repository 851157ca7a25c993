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


def test_the_arena_hands_a_steps_blocks_out_again_and_names_a_changed_step() -> None:
    from harness.engines.mjwarp.graph_loop import ArenaMismatchError, loop_steps

    sizes = iter([16, 16, 16, 32])  # the recorded step, two alike, then one that asks more
    seen: list[int] = []

    def step() -> None:
        block = wp.zeros(next(sizes) // 4, dtype=wp.int32, device="cpu")
        assert block.ptr is not None
        seen.append(int(block.ptr))

    with pytest.raises(ArenaMismatchError, match="asks 32 bytes"):
        loop_steps("cpu", step, 3, capture=False)
    assert seen[1] == seen[0] and seen[2] == seen[0]  # the recorded block, handed out again


@pytest.mark.slow
@pytest.mark.parametrize("steps", [1, 5])
def test_a_lane_step_from_the_arena_keeps_the_eager_states(steps: int) -> None:
    """FR3 cube seed 0's job in a lane: one step recording MuJoCo Warp's scratch and ``steps``
    more taking it from the arena (as in the device loop's body) give the states of plain
    eager steps bit for bit, with no allocation inside the loop's steps."""
    import mujoco_warp as mjw
    from helpers import fr3_device_jobs

    from harness.benchmarks.engines import _SCENES
    from harness.engines.mjwarp.engine import MjwarpEngine
    from harness.engines.mjwarp.graph_loop import StepArena, installed, loop_steps
    from harness.engines.mjwarp.lanes import LaneRun
    from harness.engines.mjwarp.steps import SMALL
    from harness.episode.scene_cache import get_scene

    (job,) = fr3_device_jobs(1)
    dm = MjwarpEngine("cpu").batch(get_scene(job.task, _SCENES).scene, job.task).dm

    def make(k: int) -> mjw.Data:
        return mjw.put_data(
            dm.mj_model, dm.template, nworld=k, nconmax=SMALL.nconmax, njmax=SMALL.njmax
        )

    def lanes_after(looped: bool) -> list[np.ndarray]:
        chunks = job.schedule.chunk_sizes
        lanes = LaneRun(dm, 2, 1, 512, 3, chunks, SMALL, make, interval=sum(chunks))
        span = np.array([len(job.schedule.ctrl) + 3])
        lanes.load(np.array([0]), np.array([0]), [job], span)
        lanes._physics_step()  # loads the kernels and MuJoCo Warp's per-Data caches
        if looped:
            loop_steps("cpu", lanes._physics_step, steps, capture=False)
        else:
            for _ in range(steps + 1):
                lanes._physics_step()
        return [a.numpy().copy() for a in (lanes.d.qpos, lanes.d.qvel, lanes.out)]

    plain, looped = lanes_after(False), lanes_after(True)
    for a, b in zip(plain, looped, strict=True):
        assert np.array_equal(a, b)
    assert np.abs(plain[1]).max() > 0  # the robot moved: the steps did something

    # the loop's steps allocate nothing: every block they ask for is the recorded step's
    arena = StepArena(wp.get_device("cpu").get_allocator())
    chunks = job.schedule.chunk_sizes
    lanes = LaneRun(dm, 2, 1, 512, 3, chunks, SMALL, make, interval=sum(chunks))
    lanes._physics_step()
    with installed("cpu", arena):
        lanes._physics_step()
    arena.recording, arena.armed = False, True
    recorded = len(arena.blocks)
    assert recorded > 10  # MuJoCo Warp's collision, constraint and solver scratch
    with installed("cpu", arena):
        arena.next = 0
        lanes._physics_step()
    assert arena.next == recorded and len(arena.blocks) == recorded


def test_a_loop_that_cannot_be_captured_falls_back_once_with_a_warning(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from harness.engines.mjwarp import graph_loop as gl

    monkeypatch.setattr(gl, "_failed", [])
    monkeypatch.setenv(gl.LOOP_ENV, "1")

    def refuse(device: str, step: object, times: int) -> None:
        raise RuntimeError("Conditional body graph contains an unsupported operation")

    monkeypatch.setattr(gl, "loop_steps", refuse)
    assert gl.graph_loop()
    assert gl.try_loop_steps("cpu", lambda: None, 3) is None
    assert gl.try_loop_steps("cpu", lambda: None, 3) is None
    err = capsys.readouterr().err
    assert err.count("could not be captured") == 1  # said once
    assert "unsupported operation" in err and "unrolled graphs instead" in err
    assert not gl.graph_loop()  # unrolled graphs from then on


def test_other_threads_allocate_beside_the_arena_not_from_it() -> None:
    """The arena is the device's allocator while a stream records and captures its step, and
    ``prewarm`` builds other task models on the device meanwhile: their blocks come from the
    device's own allocator, so they neither enter the step's record nor take its blocks."""
    import threading

    from harness.engines.mjwarp.graph_loop import StepArena, installed

    arena = StepArena(wp.get_device("cpu").get_allocator())
    beside: list[object] = []
    with installed("cpu", arena):
        mine = wp.zeros(4, dtype=wp.int32, device="cpu")
        worker = threading.Thread(
            target=lambda: beside.append(wp.zeros(4, dtype=wp.int32, device="cpu"))
        )
        worker.start()
        worker.join()
    assert [ptr for ptr, _ in arena.blocks] == [mine.ptr]
    (other,) = beside
    assert getattr(other, "ptr", None) not in arena.owned
    arena.recording, arena.armed = False, True
    with installed("cpu", arena):
        again = wp.zeros(4, dtype=wp.int32, device="cpu")
    assert again.ptr == mine.ptr  # the recorded block, handed out again


@pytest.mark.slow
def test_a_captured_lane_loop_replays_the_eager_states() -> None:
    """The capture path itself, on Warp's CPU device (its captures record the API calls,
    APIC, and replay them): one recording step, then a WHILE loop of 5 lane steps captured
    with MuJoCo Warp's solver loop and collision conditionals nested in its body and the
    step's scratch from the arena, launched once, gives the states of plain eager steps bit
    for bit; nothing ran while it was captured. (What a CUDA body may not hold, allocations,
    only a GPU can refuse: docs/engines.md.)"""
    import mujoco_warp as mjw
    from helpers import fr3_device_jobs

    from harness.benchmarks.engines import _SCENES
    from harness.engines.mjwarp.engine import MjwarpEngine
    from harness.engines.mjwarp.graph_loop import loop_steps
    from harness.engines.mjwarp.lanes import LaneRun
    from harness.engines.mjwarp.steps import SMALL
    from harness.episode.scene_cache import get_scene

    (job,) = fr3_device_jobs(1)
    dm = MjwarpEngine("cpu").batch(get_scene(job.task, _SCENES).scene, job.task).dm

    def make(k: int) -> mjw.Data:
        return mjw.put_data(
            dm.mj_model, dm.template, nworld=k, nconmax=SMALL.nconmax, njmax=SMALL.njmax
        )

    def fresh() -> LaneRun:
        chunks = job.schedule.chunk_sizes
        lanes = LaneRun(dm, 2, 1, 512, 3, chunks, SMALL, make, interval=sum(chunks))
        lanes.load(np.array([0]), np.array([0]), [job], np.array([len(job.schedule.ctrl) + 3]))
        lanes._physics_step()
        return lanes

    def state(lanes: LaneRun) -> list[np.ndarray]:
        return [a.numpy().copy() for a in (lanes.d.qpos, lanes.d.qvel, lanes.out)]

    plain = fresh()
    plain._physics_step()
    one_step = state(plain)
    for _ in range(5):
        plain._physics_step()
    captured = fresh()
    loop = loop_steps("cpu", captured._physics_step, 5)
    assert loop is not None
    after_recording = state(captured)
    for a, b in zip(one_step, after_recording, strict=True):  # only the recording step ran
        assert np.array_equal(a, b)
    wp.capture_launch(loop.graph)
    wp.synchronize_device("cpu")
    for a, b in zip(state(plain), state(captured), strict=True):
        assert np.array_equal(a, b)
    assert not np.array_equal(after_recording[0], state(captured)[0])  # the launch stepped
    # Warp's CPU capture owns the blocks handed out while it recorded and frees them with
    # its graph; on CUDA the arena gives them back (``LoopGraph.__del__``)
    loop.arena.blocks, loop.arena.owned = [], set()


def test_the_run_says_how_many_graphs_were_device_loops() -> None:
    """A sweep's stream line names the graphs captured as device loops (a failed capture
    falls back silently but for one warning, so the count shows which path ran), and says
    nothing of them when none was."""
    from harness.engines.mjwarp.steps import BatchTimings
    from harness.engines.mjwarp.stream_stats import StreamStats, add_timings

    total, one, other = BatchTimings(), BatchTimings(loop_graphs=1), BatchTimings(loop_graphs=3)
    add_timings(total, one)
    add_timings(total, other)
    assert total.loop_graphs == 4
    assert "; 4 graph(s) as device loops" in StreamStats(timings=total).breakdown()
    assert "device loops" not in StreamStats(timings=BatchTimings()).breakdown()


def test_an_array_that_outlives_its_arena_does_not_free_its_block_twice() -> None:
    from harness.engines.mjwarp.graph_loop import StepArena, installed

    freed: list[int] = []
    base = wp.get_device("cpu").get_allocator()
    assert base is not None

    class Counting:
        def allocate(self, size: int) -> int:
            return base.allocate(size)

        def deallocate(self, ptr: int, size: int) -> None:
            freed.append(ptr)
            base.deallocate(ptr, size)

    arena = StepArena(Counting())
    with installed("cpu", arena):
        kept = wp.zeros(4, dtype=wp.int32, device="cpu")
    arena.free()
    assert freed == [kept.ptr]
    del kept  # its deleter is the arena's: the block went back already
    assert len(freed) == 1
