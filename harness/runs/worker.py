"""Running one sweep episode, in whichever process: its row, its recording, its error row.

``execute`` is what every executor runs per episode (in the parent, a pool worker or a Ray
actor). Scenes stay cached per process. A worker that cannot produce an episode's row (a crash,
a lost worker) gets an ``error_row`` from the executor instead.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from harness.episode.candidate_cache import CandidateCache
from harness.errors import EpisodeTimeoutError
from harness.files import is_disk_full
from harness.row import identity_columns
from harness.runs.safety import inside, safe_file_name

if TYPE_CHECKING:
    from harness.episode.spec import EpisodeSpec

_SCENE_CACHE: dict[Any, Any] = {}
_CANDIDATE_CACHE: CandidateCache | None = None  # made on the first shared episode


def _candidate_cache() -> CandidateCache:
    global _CANDIDATE_CACHE
    if _CANDIDATE_CACHE is None:
        _CANDIDATE_CACHE = CandidateCache()
    return _CANDIDATE_CACHE


def execute(
    episode: EpisodeSpec, run_dir: str, record_policy: str, share: bool = True
) -> dict[str, Any]:
    """Run one episode and return its flat row; writes its recording when chosen.

    With ``share`` the episode uses this process's candidate cache
    (``harness.episode.candidate_cache``).
    An episode answered partly from it has no trace; when its recording is wanted it runs
    again without the cache (same row) to make one. An episode that no recording policy can
    want (``--record none``, or not sampled) makes no trace at all (the same row, cheaper).
    Never raises for episode-level problems: ``run_episode`` turns them into failure reasons,
    and anything that escapes it becomes an ``error`` row here. The episode runs under its
    task's limits (``limits.wall_time_s``, ``limits.sim_steps``: past them it ends as
    ``timeout``); MuJoCo's own log goes to ``RUN_DIR/MUJOCO_LOG.TXT``.
    """
    from harness.episode import run_episode  # MuJoCo and the planners: only where episodes run
    from harness.sim.budget import episode_budget
    from harness.sim.mujoco_log import log_mujoco_to

    start = time.perf_counter()
    log_mujoco_to(Path(run_dir))
    if not _may_record(episode, record_policy):  # nothing will read the viewers' trace
        episode = dataclasses.replace(episode, trace=False)
    limits = episode.task.limits
    try:
        cache = _candidate_cache() if share else None
        with episode_budget(limits.wall_time_s, limits.sim_steps):
            result = run_episode(episode, scene_cache=_SCENE_CACHE, candidate_cache=cache)
        if result.shared and _wants_recording(episode, result.row, record_policy):
            with episode_budget(limits.wall_time_s, limits.sim_steps):
                result = run_episode(episode, scene_cache=_SCENE_CACHE)  # for its trace
        row = dict(result.row)
    except EpisodeTimeoutError as exc:  # the alarm fired after run_episode's own handlers
        result = None
        row = error_row(episode, str(exc))
        row["failure_reason"] = "timeout"
    except Exception as exc:  # the last line of defence; run_episode already catches
        result = None
        row = error_row(episode, f"{type(exc).__name__}: {exc}")
    row.update(identity_columns(episode))
    row.setdefault("wall_time_s", time.perf_counter() - start)
    row["worker_peak_rss_mb"] = _peak_rss_mb()
    wants = _wants_recording(episode, row, record_policy)
    if wants and result is not None and getattr(result, "trace", None) is not None:
        _record(result, episode, Path(run_dir), row)
    return row


def invalid_success(row: dict[str, Any]) -> bool:
    """A reference success whose validity phase judged it not physically valid."""
    reason = str(row.get("invalid_reason") or "")
    return bool(row.get("success")) and not bool(row.get("valid")) and reason not in ("", "not_run")


def _may_record(episode: EpisodeSpec, record_policy: str) -> bool:
    """Whether ``_wants_recording`` can hold for the episode, whatever its row."""
    return episode.record or record_policy in ("failures", "invalid")


def _wants_recording(episode: EpisodeSpec, row: dict[str, Any], record_policy: str) -> bool:
    """The episode is recorded: chosen for it (``all``, ``sample:N``), or under ``failures`` a
    failure or an invalid reference success, or under ``invalid`` an invalid success only."""
    if episode.record:
        return True
    if record_policy == "failures":
        return not bool(row.get("success")) or invalid_success(row)
    return record_policy == "invalid" and invalid_success(row)


def _record(result: Any, episode: EpisodeSpec, run_dir: Path, row: dict[str, Any]) -> None:
    """Write the episode's recording whole, or leave none and say why in ``recording_error``
    (``disk full: ...`` on ENOSPC, which stops the run; see ``recording_disk_full``)."""
    try:
        from harness.viz.recording import record_episode

        name = safe_file_name(episode.resolved_id, ".rrd")
        path = inside(run_dir, run_dir / "episodes" / name)
        record_episode(result, path, episode.task)
        row["recording"] = str(path.relative_to(run_dir))
    except Exception as exc:  # a recording problem must not lose the episode
        prefix = DISK_FULL_PREFIX if is_disk_full(exc) else ""
        row["recording_error"] = f"{prefix}{type(exc).__name__}: {exc}"


DISK_FULL_PREFIX = "disk full: "


def recording_disk_full(row: dict[str, Any]) -> bool:
    """True when the row's recording failed because the disk is full (the run must stop)."""
    return str(row.get("recording_error") or "").startswith(DISK_FULL_PREFIX)


def _peak_rss_mb() -> float:
    """Peak resident memory of this process in MiB.

    Linux: ``VmHWM`` -- a spawned worker's ``ru_maxrss`` carries the parent's RSS across
    fork + exec and over-reports. Elsewhere ``ru_maxrss`` (KiB on Linux, bytes on macOS).
    """
    try:
        with open("/proc/self/status", encoding="ascii") as handle:
            for line in handle:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    import resource
    import sys

    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / (1024 * 1024) if sys.platform == "darwin" else peak / 1024


def error_row(episode: EpisodeSpec, message: str) -> dict[str, Any]:
    """The row of an episode that could not produce its own (crash, lost worker)."""
    task = episode.task
    row = identity_columns(episode)
    row.update(
        {
            "semantics": task.pick.semantics,
            "test_mode": task.pick.test_mode,
            "timing": task.pick.timing,
            "success": False,
            "failure_reason": "error",
            "error_message": message,
        }
    )
    return row
