"""One pick episode, as a package: what defines it, its stages, its randomness, its caches.

- ``spec``: ``EpisodeSpec``, what defines an episode (no MuJoCo: the runners import it freely);
- ``ids``: episode ids and seeds; ``streams``: one random stream per purpose;
- ``pipeline``: ``run_episode`` and the row's identity columns (``base_row``);
- the stages in order: ``setup`` (reset), ``planning`` (candidates, feasibility),
  ``execution`` (the chosen candidate's plan and execution);
- ``handover``: a handover's second pick, after the first arm's pick and goto in the same
  scene (``TaskConfig.handover``);
- ``result``: ``EpisodeResult``; ``trace``: the per-step record for viewers;
- ``candidate_cache``: the per-worker memory of seed evaluations shared between points;
  ``scene_cache``: the per-worker built scenes, planners and grasp poses.

The names below are imported on first use, so ``import harness.episode.spec`` stays light
(importing a submodule runs this file first).
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # what the lazy attributes below resolve to
    from harness.episode.pipeline import base_row, run_episode
    from harness.episode.result import EpisodeResult
    from harness.episode.setup import INIT_RECORD_TIME_S, SETTLE_TIME_S, WARMUP_TIME_S
    from harness.episode.spec import EpisodeSpec

_LAZY = {
    "EpisodeSpec": "harness.episode.spec",
    "EpisodeResult": "harness.episode.result",
    "run_episode": "harness.episode.pipeline",
    "base_row": "harness.episode.pipeline",
    "INIT_RECORD_TIME_S": "harness.episode.setup",
    "SETTLE_TIME_S": "harness.episode.setup",
    "WARMUP_TIME_S": "harness.episode.setup",
}
__all__ = [
    "INIT_RECORD_TIME_S",
    "SETTLE_TIME_S",
    "WARMUP_TIME_S",
    "EpisodeResult",
    "EpisodeSpec",
    "base_row",
    "run_episode",
]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'harness.episode' has no attribute {name!r}")
