"""``--backend ray --engine mjwarp``: one device stream actor per node, planning on every core.

The Ray form of ``harness.runs.device_pool``: a ``DeviceActor`` per node that has GPUs (all of
that node's GPUs as Ray resources: ``num_gpus``; its ``DeviceStreams`` runs a lane stream on
each), or one on the driver's node when no node has a GPU (Warp's CPU device: tests). Planning
actors (one CPU each, spread over every node's cores) run up to ``depth`` episodes at once in
threads, one planning at a time (the ``Baton``); an episode's job goes to its node's device
actor (else any) and the actor's next episode plans meanwhile. Rows come back as each episode
finishes; an actor that dies is restarted and its episode run again (``CRASH_RETRIES``), then an
``error`` row.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from harness.runs.scheduling import shared_order
from harness.runs.spawning import CRASH_RETRIES

if TYPE_CHECKING:
    from harness.episode.spec import EpisodeSpec
    from harness.runs.executors import OnResult, RunStats


class _DeviceStreamsHost:
    """(Inside the device actor) the node's ``DeviceStreams``; ``run`` awaits one job."""

    def __init__(self, devices: list[str] | None, episodes: int) -> None:
        from harness.engines.mjwarp.devices import DeviceStreams
        from harness.engines.mjwarp.engine import default_devices

        self.streams = DeviceStreams(devices or default_devices())
        self.streams.episodes = episodes
        self.count = 0

    async def run(self, job: Any) -> tuple[Any, str | None]:
        loop = asyncio.get_running_loop()
        done: asyncio.Future[tuple[Any, str | None]] = loop.create_future()
        self.count += 1

        def answer(outcome: Any, error: str | None) -> None:
            loop.call_soon_threadsafe(done.set_result, (outcome, error))

        self.streams.submit(self.count, job, answer)
        return await done

    def stats(self) -> Any:
        return self.streams.stats


class _Planner:
    """(Inside a planning actor) episodes in threads, one planning at a time."""

    def __init__(self, device: Any, run_dir: str, record: str, share: bool, depth: int) -> None:
        import itertools
        import threading

        import ray

        from harness.engines import register_engine
        from harness.engines.mjwarp.service import Baton, DeviceReply, PooledDeviceEngine
        from harness.episode.outcome_wait import set_waiter
        from harness.runs.worker import reserve_candidate_cache

        self.run_dir, self.record, self.share = run_dir, record, share
        self.baton = Baton(lambda track: None)
        self.tracks = itertools.count(1)  # next() is atomic: the actor's threads call it
        set_waiter(self.baton.wait_elsewhere)  # a seed's outcome in flight: plan meanwhile
        reserve_candidate_cache(depth)

        def send(request: Any) -> None:  # the job to the device actor; its reply to the baton
            ref = device.run.remote(request.job)

            def deliver() -> None:
                try:
                    outcome, error = ray.get(ref)
                except Exception as exc:  # the device actor died: the episode's error row
                    outcome, error = None, f"{type(exc).__name__}: {exc}"
                self.baton.deliver(DeviceReply(request.track, outcome, error))

            threading.Thread(target=deliver, daemon=True).start()

        register_engine(PooledDeviceEngine(send, self.baton))

    def run(self, episode: Any) -> dict[str, Any]:
        from harness.runs.worker import execute

        track = next(self.tracks)
        self.baton.hold(track)
        try:
            return execute(episode, self.run_dir, self.record, self.share)
        finally:
            self.baton.release()


def device_actors(ray: Any, episodes: int) -> list[Any]:
    """One device actor per node with GPUs (all its GPUs), else one on this node (CPU)."""
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    host = ray.remote(num_cpus=0)(_DeviceStreamsHost)
    actors = []
    for node in ray.nodes():
        gpus = int(node.get("Resources", {}).get("GPU", 0)) if node.get("Alive") else 0
        if gpus:
            strategy = NodeAffinitySchedulingStrategy(node["NodeID"], soft=False)
            devices = [f"cuda:{k}" for k in range(gpus)]
            actors.append(
                host.options(num_gpus=gpus, scheduling_strategy=strategy).remote(devices, episodes)
            )
    if not actors:
        actors.append(host.remote(None, episodes))
    return actors


def run_on_ray_device(
    ray: Any,
    episodes: list[EpisodeSpec],
    run_dir: str,
    record: str,
    on_result: OnResult,
    workers: int,
    share: bool,
    stats: RunStats,
    error_row: Callable[[Any, str], dict[str, Any]],
) -> None:
    """The episodes on planning actors feeding the nodes' device actors (module docstring)."""
    from harness.engines.mjwarp.lane_sizes import default_lanes
    from harness.runs.device_pool import depth_for

    devices = device_actors(ray, len(episodes))
    count = max(1, min(workers, len(episodes)))
    gpu = ray.cluster_resources().get("GPU", 0) > 0
    lanes = default_lanes("cuda:0" if gpu else "cpu", len(episodes))
    depth = depth_for(lanes, len(devices), count)
    planner = ray.remote(num_cpus=1, max_restarts=-1, max_task_retries=CRASH_RETRIES)(_Planner)
    actors = [
        planner.options(max_concurrency=depth + 1).remote(
            devices[k % len(devices)], run_dir, record, share, depth
        )
        for k in range(count)
    ]
    start = time.perf_counter()
    pending = iter(shared_order(episodes) if share else episodes)
    in_flight: dict[Any, tuple[Any, Any, float]] = {}  # actor, episode, when submitted
    load = dict.fromkeys(range(count), 0)

    def submit(k: int) -> None:
        while load[k] < depth:
            episode = next(pending, None)
            if episode is None:
                return
            in_flight[actors[k].run.remote(episode)] = (k, episode, time.perf_counter())
            load[k] += 1

    try:
        for k in range(count):
            submit(k)
        while in_flight:
            done, _ = ray.wait(list(in_flight), num_returns=1)
            k, episode, submitted = in_flight.pop(done[0])
            load[k] -= 1
            try:
                row = ray.get(done[0])
            except Exception as exc:  # the actor died again after its retries
                row = error_row(episode, f"ray worker failed: {type(exc).__name__}")
                stats.crashed += 1
            on_result(row)
            stats.finished += 1
            stats.lives += 1  # Little's law line (harness.runs.pace.flight_line)
            stats.lives_s += time.perf_counter() - submitted
            submit(k)
        stats.device = ray.get(devices[0].stats.remote())
    except KeyboardInterrupt:
        stats.interrupted = True
        for ref in in_flight:
            ray.cancel(ref, force=True)
    stats.wall_time_s = time.perf_counter() - start
