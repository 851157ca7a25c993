"""The order episodes run in: points that can share candidate evaluations run together.

Two episodes share a seed's evaluations (``harness.episode.candidate_cache``) when their tasks
differ only in selection keys and their seeds are equal. ``share_groups`` collects them, in order of
first appearance, so a worker runs a group back to back and its cache answers every episode
after the first from what the first ones evaluated. Groups keep the rows identical; they only
change which worker runs what and when.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from harness.episode.candidate_cache import physics_key

if TYPE_CHECKING:
    from harness.episode.spec import EpisodeSpec


def share_groups(episodes: list[EpisodeSpec]) -> list[list[EpisodeSpec]]:
    """``episodes`` grouped by (task without selection keys, seed), first appearance first."""
    keys_of_task: dict[int, str] = {}  # the same task object serves every episode of a point
    groups: dict[tuple[str, int], list[EpisodeSpec]] = {}
    for episode in episodes:
        task_key = keys_of_task.get(id(episode.task))
        if task_key is None:
            task_key = keys_of_task[id(episode.task)] = physics_key(episode.task)
        groups.setdefault((task_key, episode.seed), []).append(episode)
    return list(groups.values())


def shared_order(episodes: list[EpisodeSpec]) -> list[EpisodeSpec]:
    """``episodes`` reordered so every share group is contiguous."""
    return [episode for group in share_groups(episodes) for episode in group]
