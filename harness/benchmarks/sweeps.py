"""Sweep throughput: episodes per second with 1 and 2 process-pool workers, and worker memory.

Both runs execute the same episodes (an FR3 cube task, ik mode, toppra) back to back in one
``harness bench`` invocation, so the scaling ratio is measured under the same machine load.
Worker start-up (imports, scene build) is included in the wall time and also reported apart.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from harness.bench import Figure, figure
from harness.config import load_task
from harness.sweep import SweepEpisode, episode_id, episode_seed, run_process_pool

ROOT = Path(__file__).resolve().parents[2]


def _episodes(count: int) -> list[SweepEpisode]:
    task = load_task(ROOT / "tasks" / "pick" / "fr3.yaml")
    task = task.model_copy(
        update={"pick": task.pick.model_copy(update={"test_mode": "ik", "timing": "toppra"})}
    )
    return [
        SweepEpisode(
            episode_id=episode_id(task.name, {}, index),
            task=task,
            task_name=task.name,
            point_id=0,
            point={},
            episode_index=index,
            seed=episode_seed(0, index),
            run="bench",
        )
        for index in range(count)
    ]


def _throughput(workers: int, count: int) -> tuple[float, float, list[float]]:
    """Episodes/s over the whole pool run, time to first result, peak RSS per worker (MiB)."""
    rows: list[dict] = []
    first: list[float] = []
    start = time.perf_counter()

    def on_result(row: dict) -> None:
        if not first:
            first.append(time.perf_counter() - start)
        rows.append(row)

    with tempfile.TemporaryDirectory() as run_dir:
        stats = run_process_pool(_episodes(count), Path(run_dir), "none", on_result, workers)
    memory = [float(row.get("worker_peak_rss_mb", float("nan"))) for row in rows]
    return stats.finished / stats.wall_time_s, first[0] if first else float("nan"), memory


def run(quick: bool) -> list[Figure]:
    count = 8 if quick else 24
    one, first_one, memory_one = _throughput(1, count)
    two, first_two, memory_two = _throughput(2, count)
    scaling = two / one
    return [
        figure(
            "sweeps",
            "episodes/s, 1 worker",
            [one],
            "ep/s",
            higher_is_better=True,
            notes=f"{count} FR3 episodes incl. worker start-up ({first_one:.2f} s to first)",
        ),
        figure(
            "sweeps",
            "episodes/s, 2 workers",
            [two],
            "ep/s",
            higher_is_better=True,
            notes=f"{count} FR3 episodes incl. worker start-up ({first_two:.2f} s to first)",
        ),
        figure(
            "sweeps",
            "scaling 1 -> 2 workers",
            [scaling],
            "x",
            target=1.8,
            higher_is_better=True,
            notes="ratio of the two rows above, same run",
        ),
        figure(
            "sweeps",
            "peak memory per worker",
            memory_one + memory_two,
            "MiB",
            notes="ru_maxrss of each worker after each episode",
        ),
    ]
