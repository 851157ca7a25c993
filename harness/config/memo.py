"""Memoising a pure function of a task per task object.

A sweep point's task is one object shared by all its episodes, and a dense grid asks the same
questions of it per episode (its scene key, its physics key). Tasks are never mutated after
validation (overrides make copies), so the answer can be kept per object. The memo holds the
task itself, so an ``id`` is never reused while its entry lives.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import TypeVar

from harness.config.task import TaskConfig

R = TypeVar("R")

MEMO_SIZE = 4096  # entries per function before the memo starts over


def per_task(function: Callable[[TaskConfig], R]) -> Callable[[TaskConfig], R]:
    """``function(task)`` computed once per task object."""
    memo: dict[int, tuple[TaskConfig, R]] = {}

    @functools.wraps(function)
    def memoised(task: TaskConfig) -> R:
        hit = memo.get(id(task))
        if hit is not None and hit[0] is task:
            return hit[1]
        value = function(task)
        if len(memo) >= MEMO_SIZE:
            memo.clear()
        memo[id(task)] = (task, value)
        return value

    return memoised
