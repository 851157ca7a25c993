"""Measure: the batched engine's tug round policies on real rung outcomes, without a device.

Runs episodes on the CPU ``mujoco`` engine with every one of the 24 tug rungs computed (a rung
starts from the held state, so running all of them changes no result), then replays each
tugged episode's rung outcomes through ``harness.engines.mjwarp.tug.run_rounds`` under each
``RoundPolicy``: rounds (device batches) and rung-worlds (worlds stepped for 0.5 s each) per
policy, and a check that every policy's ladder gives the CPU row's ``robustness_g``.

``python -m harness.benchmarks.tug_rounds SEEDS [ARM ...] [KEY=VALUE ...]`` (default: the five
canonical arms; objects cube and banana; ``KEY=VALUE``: task overrides, e.g.
``object.mass=0.4``, for grasps that give way below the top level).
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any

from harness.benchmarks.engines import ARMS, OBJECTS, specs, tasks
from harness.config import apply_overrides
from harness.engines.mjwarp.tug import RUNGS, RoundPolicy, Rung, run_rounds, walk
from harness.pick import validity
from harness.pick.validity import RungOutcome
from harness.runs.expansion import point_overrides

_Ladder = Callable[[Callable[[str, tuple[float, float, float], float], RungOutcome]], Any]


def _recording(patterns: list[dict[Rung, RungOutcome]], ladder: _Ladder) -> _Ladder:
    """``tug_ladder`` that first runs all 24 rungs and keeps their outcomes."""
    directions = dict(validity.TUG_DIRECTIONS)

    def full(rung: Callable[[str, tuple[float, float, float], float], RungOutcome]) -> Any:
        pattern = {(name, k): rung(name, directions[name], k) for name, k in RUNGS}
        patterns.append(pattern)
        return ladder(lambda name, direction, k: pattern[(name, k)])

    return full


def collect(
    seeds: int, arms: tuple[str, ...], overrides: dict[str, Any]
) -> list[tuple[str, dict[Rung, RungOutcome], float]]:
    """(task label, the 24 rung outcomes, the row's robustness_g) per tugged CPU episode."""
    from harness.episode import run_episode

    cache: dict[Any, Any] = {}
    found = []
    original = validity.tug_ladder
    try:
        task_list = [
            apply_overrides(t, point_overrides(t, overrides)) for t in tasks(arms, OBJECTS)
        ]
        for spec in specs(task_list, seeds):
            patterns: list[dict[Rung, RungOutcome]] = []
            validity.tug_ladder = _recording(patterns, original)  # type: ignore[assignment]
            row = run_episode(spec, cache).row
            if patterns:
                label = f"{row['robot']}:{row['arm']} {row['object']}"
                found.append((label, patterns[0], float(row["robustness_g"])))
    finally:
        validity.tug_ladder = original  # type: ignore[assignment]
    return found


def _answer(
    worlds: list[dict[Rung, RungOutcome]],
) -> Callable[[list[tuple[int, Rung]]], list[RungOutcome]]:
    return lambda batch: [worlds[w][r] for w, r in batch]


def _setting(text: str) -> tuple[str, Any]:
    key, value = text.split("=", 1)
    try:
        return key, float(value)
    except ValueError:
        return key, value


def main(argv: list[str]) -> None:
    seeds = int(argv[0])
    arms = tuple(a for a in argv[1:] if "=" not in a) or ARMS
    overrides = dict(_setting(a) for a in argv[1:] if "=" in a)
    found = collect(seeds, arms, overrides)
    print(f"{len(found)} tugged episodes of {seeds} seeds x {arms} x {OBJECTS} {overrides}")
    groups: dict[str, list[int]] = {}
    for i, (label, _, _) in enumerate(found):
        groups.setdefault(label, []).append(i)
    for policy in RoundPolicy:
        line = []
        total = 0
        for label, members in groups.items():
            worlds = [found[i][1] for i in members]
            known, stats = run_rounds(list(range(len(worlds))), _answer(worlds), policy)
            for w, i in enumerate(members):
                assert walk(known[w]).result[0] == found[i][2], (label, i)
            total += stats.rungs
            line.append(f"{label} {stats.rounds}r/{stats.rungs}")
        per = total / max(1, len(found))
        print(f"{policy.value:10s} rung-worlds {total} ({per:.2f}/episode); " + ", ".join(line))
    levels: dict[float, int] = {}
    for _, _, robustness in found:
        levels[robustness] = levels.get(robustness, 0) + 1
    print("robustness_g counts", dict(sorted(levels.items())))


if __name__ == "__main__":
    main(sys.argv[1:])
