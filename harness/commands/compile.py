"""``harness compile TASK_OR_SWEEP``: compile the mjwarp engine's kernels of every task model of
a task or sweep YAML into Warp's kernel cache, with a progress line per model and device
(``harness.runs.warm``)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import yaml

from harness.errors import HarnessError


def main(args: argparse.Namespace) -> int:
    from harness.config import load_sweep, load_task
    from harness.engines.mjwarp.devices import CPU_DEVICE_NOTE
    from harness.engines.mjwarp.engine import default_devices
    from harness.episode import EpisodeSpec
    from harness.runs.expansion import expand
    from harness.runs.warm import model_jobs, warm

    path = Path(args.path)
    try:
        data = yaml.safe_load(path.read_text())
    except OSError as exc:
        raise HarnessError(f"{path}: {exc.strerror or exc}") from None
    if isinstance(data, dict) and "tasks" in data:
        episodes = expand(load_sweep(path), path)
    else:
        task = load_task(path)
        episodes = [EpisodeSpec(task=task, seed=s, episode_index=s) for s in range(8)]
    devices = default_devices()

    def say(line: str) -> None:
        print(f"compile: {line}", file=sys.stderr, flush=True)

    if "cpu" in devices:
        say(CPU_DEVICE_NOTE)
    say(f"planning one episode of each task model of {path} ...")
    jobs = model_jobs(episodes)
    if not jobs:
        raise HarnessError(f"{path}: no episode of it reached its execution in 8 seeds")
    spent = warm(jobs, devices, say)
    print(
        f"{len(jobs)} task model(s) on {', '.join(devices)}: kernels in Warp's cache "
        f"({sum(spent.values()):.1f} s)"
    )
    return 0
