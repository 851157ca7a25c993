"""An episode's randomness: one independent stream per purpose, derived from the episode seed.

Each purpose gets its own ``numpy.random.Generator`` from ``SeedSequence(seed, spawn_key=...)``,
so what one stage draws never shifts another stage's numbers:

- ``scene``: the reset (robot root, object placement and orientation, home noise);
- ``candidates``: the candidate draw (``reference``: 20 weighted draws with replacement;
  ``strict`` with ``strict_sampling`` only);
- ``lift``: the post-grasp lift offset;
- ``planner(pose_index)``: the feasibility test of one annotated grasp (IK restarts, RRT
  samples, shortcuts);
- ``execution(pose_index)``: the executed plan of one chosen grasp (when it is re-planned).

The candidate's own streams make its feasibility and its executed outcome depend only on (task
physics, seed, candidate): whichever filter setting selects it, and whatever was tested before
it, the answer is the same. That is what lets sweep points that differ only in their selection
keys share one evaluation per candidate (``harness.episode.candidate_cache``).

The reference draws from two global streams (Python ``random`` for the candidate draw, NumPy for
the scene and the lift offset, docs/reference-pick-skill.md quirk 22); the distributions here are
the same, the numbers cannot be.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Spawn keys of the purposes (the first element of a stream's spawn key). Changing one changes
# every row: they are part of the row's definition, like the seed.
SCENE_STREAM = 0
CANDIDATE_STREAM = 1
LIFT_STREAM = 2
PLANNER_STREAM = 3
EXECUTION_STREAM = 4
# A handover's later phases (harness.episode.handover): the goto's draws, and every stream of the
# second pick, apart from the first pick's (which uses the purposes above).
GOTO_STREAM = 5
SECOND_PICK_STREAM = 6


@dataclass(frozen=True)
class EpisodeStreams:
    """The independent random streams of one episode seed (see the module docstring)."""

    seed: int

    def _stream(self, *key: int) -> np.random.Generator:
        return np.random.default_rng(np.random.SeedSequence(self.seed, spawn_key=key))

    def scene(self) -> np.random.Generator:
        """The reset: robot root, object placements and orientations, home noise."""
        return self._stream(SCENE_STREAM)

    def candidates(self) -> np.random.Generator:
        """The candidate draw of the selection."""
        return self._stream(CANDIDATE_STREAM)

    def lift(self) -> np.random.Generator:
        """The post-grasp lift offset."""
        return self._stream(LIFT_STREAM)

    def planner(self, pose_index: int) -> np.random.Generator:
        """The feasibility test of the annotated grasp ``pose_index``."""
        return self._stream(PLANNER_STREAM, pose_index)

    def execution(self, pose_index: int) -> np.random.Generator:
        """The executed plan of the chosen grasp ``pose_index``."""
        return self._stream(EXECUTION_STREAM, pose_index)


@dataclass(frozen=True)
class HandoverStreams(EpisodeStreams):
    """The streams of a handover's goto and second pick: the second pick's purposes live under
    ``SECOND_PICK_STREAM``, so they differ from the first pick's of the same seed."""

    def _stream(self, *key: int) -> np.random.Generator:
        spawn_key = (SECOND_PICK_STREAM, *key)
        return np.random.default_rng(np.random.SeedSequence(self.seed, spawn_key=spawn_key))

    def goto(self) -> np.random.Generator:
        """The goto's rotations, position noise and planner seeds."""
        return np.random.default_rng(np.random.SeedSequence(self.seed, spawn_key=(GOTO_STREAM,)))
