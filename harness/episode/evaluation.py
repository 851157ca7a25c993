"""One episode's view of its seed's memory: reuse what is known, compute and keep what is not.

Every stage asks ``SeedEvaluation`` rather than the cache: the reset's facts (``facts``), the
candidates' verdicts (``walk``), the chosen candidate's executed outcome (``executed``). Each
answer from memory counts as a hit in the cache's ``CacheStats`` and marks the episode
``used_shared`` (its trace is then not kept: pieces of it belong to other episodes); each
computed answer is stored and counted. It also keeps the scene's ``reset_mark``
(``harness.episode.scene_cache.SceneBundle``): which seed's untouched reset the scene holds, so
a stage that must compute on the reset state re-runs the reset only when the scene left it.

Without a shared cache the memory starts empty and every answer is computed, as an unshared
episode always did; the row is the same either way (tests/test_candidate_cache.py).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from harness.episode.candidate_cache import ExecutedOutcome, ResetFacts, SeedMemory
from harness.episode.scene_cache import SceneBundle
from harness.pick.selection import walk_candidates
from harness.planning.plans import CandidateVerdict
from harness.sim import Scene


def _scene_state(scene: Scene) -> tuple[np.ndarray, ...]:
    d = scene.data
    return (d.qpos.copy(), d.qvel.copy(), d.ctrl.copy(), np.array([d.time]))


class SeedEvaluation:
    """The sharing bookkeeping of one episode on ``memory`` (the entry of ``key``)."""

    def __init__(self, memory: SeedMemory | None = None, key: Any = None) -> None:
        self.memory = memory if memory is not None else SeedMemory()
        self.key = key  # which reset the scene must hold
        self.used_shared = False  # answered partly from evaluations of earlier episodes

    @property
    def known_reset(self) -> ResetFacts | None:
        return self.memory.reset

    def facts(self, run_reset: Callable[[], ResetFacts]) -> ResetFacts:
        """The reset's facts: from memory (a hit), else ``run_reset()`` (kept)."""
        if self.memory.reset is None:
            self.memory.reset = run_reset()
        else:
            self.used_shared = True
            self.memory.stats.reset_hits += 1
        return self.memory.reset

    def count_reset(self) -> None:
        """A reset ran (the first, or a repeat to bring the scene back to it)."""
        self.memory.stats.resets += 1

    # -- the scene's reset mark --------------------------------------------------------------

    def holds_reset(self, bundle: SceneBundle) -> bool:
        """The scene holds this seed's reset, untouched since it ran."""
        mark = bundle.reset_mark
        if mark is None or mark[0] != self.key:
            return False
        now = _scene_state(bundle.scene)
        return all(np.array_equal(a, b) for a, b in zip(mark[1], now, strict=True))

    def mark_reset(self, bundle: SceneBundle) -> None:
        """The scene now holds this seed's reset."""
        bundle.reset_mark = (self.key, _scene_state(bundle.scene))

    @staticmethod
    def mark_stepped(bundle: SceneBundle) -> None:
        """The scene is about to leave the reset state."""
        bundle.reset_mark = None

    # -- candidates and the executed outcome --------------------------------------------------

    def walk(
        self,
        indices: list[int],
        scores: list[float],
        test: Callable[[int, int, float], CandidateVerdict],
    ) -> tuple[list[CandidateVerdict], CandidateVerdict | None]:
        """``walk_candidates`` over ``indices``, reusing the verdicts already known."""
        known = self.memory.verdicts
        known_before = set(known)
        verdicts, chosen = walk_candidates(indices, scores, test, known)
        reused = {v.pose_index for v in verdicts} & known_before
        stats = self.memory.stats
        stats.verdict_hits += len(reused)
        stats.verdicts += len(known) - len(known_before)
        if reused:
            self.used_shared = True
        return verdicts, chosen

    def executed(
        self, pose_index: int, execute: Callable[[], ExecutedOutcome]
    ) -> tuple[ExecutedOutcome, bool]:
        """The executed outcome of the chosen ``pose_index``, and whether it came from memory
        (a share group's episodes run one after another, so an outcome is there or not)."""
        memory = self.memory
        outcome = memory.outcomes.get(pose_index)
        if outcome is not None:
            self.used_shared = True
            memory.stats.outcome_hits += 1
            return outcome, True
        outcome = execute()
        memory.outcomes[pose_index] = outcome
        memory.stats.outcomes += 1
        return outcome, False
